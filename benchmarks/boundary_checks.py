"""The numbers of docs/validation.md, "Outlets, inflows and the wall": every check of the tests on the boundary
conditions (tests/timestepping/test_outlets.py, tests/fem/test_inflow.py, test_support.py, test_materials.py,
tests/io/test_surfaces.py, tests/experiments/test_reflection.py, tests/verification/test_materials_convergence.py),
at the tests' resolutions and at the finer ones of their slow versions, as JSON.

Run: PYTHONPATH=src python benchmarks/boundary_checks.py [--fine] > boundary_checks.json   (fast: a minute; --fine:
about 20 minutes on 2 cores)
"""
import json
import sys
import tempfile
from pathlib import Path

import ngsolve as ngs
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from experiments import test_reflection as reflection  # noqa: E402
from fem import test_inflow as inflow  # noqa: E402
from fem import test_support as support  # noqa: E402
from support.channels import at_rest, channel_scheme, history, mean_over, rigid  # noqa: E402
from timestepping import test_outlets as outlets  # noqa: E402
from verification import test_materials_convergence as materials  # noqa: E402

from fsivsp.config.case import load_study_case  # noqa: E402
from fsivsp.experiments.study import study  # noqa: E402
from fsivsp.io.surfaces import Surfaces  # noqa: E402
from fsivsp.model.data import FlowRate, Windkessel, resistance  # noqa: E402
from fsivsp.model.expressions import parse  # noqa: E402

SCHEMES = ("backward_euler", "crank_nicolson", "bdf2")


def resistance_outlet() -> dict:
    out = {}
    for scheme in SCHEMES:
        data = at_rest(velocity={"solid_ends|solid_wall": [0, 0]},
                       traction={"inflow": [f"{outlets.P_IN}*(1 - exp(-t**2/0.01))", 0]},
                       outlets={"outflow": resistance(outlets.R_OUT)})
        run = channel_scheme(data, rigid(outlets.NU), 0.05, scheme, length=outlets.LENGTH)
        q = history(run, 120, flow=lambda s: s.outlet_flows()[0])["flow"][-1]
        p_out = mean_over(run.spaces.mesh, run.pressure, "outflow")
        poiseuille = 3 * outlets.NU * outlets.LENGTH / (2 * outlets.RADIUS**3)
        out[scheme] = {"p_out/(RQ) - 1": p_out / (outlets.R_OUT * q) - 1,
                       "Q/(P_in/(R + R_pois)) - 1": q / (outlets.P_IN / (outlets.R_OUT + poiseuille)) - 1,
                       "P - RQ": run.outlets[0].pressure - outlets.R_OUT * q}
    return out


def windkessel_order() -> dict:
    out = {}
    for scheme in SCHEMES:
        errors = []
        for dt in (0.02, 0.01, 0.005):
            data = at_rest(velocity={"interface|solid_ends|solid_wall": [0, 0]},
                           boundary_flow={"inflow": FlowRate(parse("sin(2*pi*t)", "flow"))},
                           outlets={"outflow": Windkessel(outlets.RP, outlets.C, outlets.RD, parse("0.3*t", "p"))})
            run = channel_scheme(data, rigid(0.1), dt, scheme, maxh=0.2, length=1.0,
                                 dirichlet="inflow|interface|solid_ends|solid_wall")
            record = history(run, round(1 / dt), pressure=lambda s: s.outlets[0].pressure)
            errors.append(float(np.abs(record["pressure"] - outlets.rcr_pressure(record["time"])).max()))
        out[scheme] = {"errors": errors, "orders": np.log2(np.array(errors[:-1]) / errors[1:]).tolist()}
    return out


def discrete_flux() -> dict:
    out = {}
    for dim, family in ((2, "taylor_hood"), (2, "mini"), (3, "taylor_hood")):
        for name, flow in [(p, parse(inflow.WAVE, "flow")) for p in ("plug", "parabolic", "womersley")] \
                + [("womersley (table)", inflow.TABLE)]:
            rate = FlowRate(flow, name.split()[0], 1.0, 10)
            data = at_rest(dim, velocity={"solid_ends|solid_wall": [0] * dim}, boundary_flow={"inflow": rate})
            run = channel_scheme(data, rigid(0.1), 0.05, "bdf2", maxh=0.1 if dim == 2 else 0.5,
                                 length=2.0 if dim == 2 else 1.0, dirichlet="inflow|solid_ends|solid_wall",
                                 family=family, dim=dim)
            inward, q = run.inflows["inflow"].inward, rate.function()
            record = history(run, 6, flux=lambda s, inward=inward: inward.InnerProduct(s.state.vec))
            out[f"{dim}D {family} {name}"] = float(np.abs(record["flux"] - [q(t) for t in record["time"]]).max() / 2.5)
    return out


def reflections(fine: bool) -> dict:
    length, maxh, dt = (10.0, 0.05, 5e-4) if fine else (5.0, 0.1, 0.002)
    z = reflection.IMPEDANCE
    cases = {"traction-free": {}, "RCR R_p = Z": reflection.tuned(), "resistance Z": {"outflow": Windkessel(z)},
             "RCR R_p = Z/4": {"outflow": Windkessel(z / 4, 0.05, 10 * z)},
             "RCR R_p = 4Z": {"outflow": Windkessel(4 * z, 0.05, 10 * z)}}
    measured = {label: reflection.reflection(o, length, maxh, dt) for label, o in cases.items()}
    free = measured["traction-free"][0]
    return {"set-up": {"L": length, "maxh": maxh, "dt": dt, "c": reflection.SPEED, "Z": z},
            **{label: {"|P-| / incident": back / incident, "of the traction-free outlet's": back / free}
               for label, (back, incident) in measured.items()}}


def two_materials() -> dict:
    with tempfile.TemporaryDirectory() as folder:
        case = load_study_case({
            "geometry": {"kind": "cad", "dim": 2, "maxh": 0.25,
                         "path": str(materials.layers(Path(folder) / "layers.step")), "regions": {"plaque": "solid"}},
            "materials": {"rho_fluid": 1.0, "rho_solid": 2.0, "nu": 0.5, "lam": 1.5, "mu": 0.75,
                          "plaque": {"rho_solid": 1.0, "lam": 12.0, "mu": 4.0}},
            "time": {"T": 0.1, "dt": 0.02}, "discretisation": {"family": "taylor_hood", "order": 1},
            "exact": materials.EXACT})
        records = study(case, range(0, 3))
    return {name: {"errors": [r["errors"][name] for r in records], "rates": [r["rates"][name] for r in records[1:]]}
            for name in ("v1", "v2", "p", "sigma")}


def poiseuille_wss() -> dict:
    data = at_rest(velocity={"solid_ends|solid_wall": [0, 0]}, traction={"inflow": ["10*(1 - exp(-t**2/0.01))", 0]})
    out = {}
    for family, maxh in (("taylor_hood", 0.1), ("mini", 0.1), ("mini", 0.05)):
        run = channel_scheme(data, rigid(1.0), 0.02, "backward_euler", length=5.0, maxh=maxh, family=family)
        run.march(60)
        surfaces = Surfaces(run, ["outflow", "interface"])
        _, wss = surfaces.interface_fields()
        tau = 3 * surfaces.values()["outflow.flow"] / (2 * 0.25)
        mesh = run.spaces.mesh
        shear = [wss(mesh(x, y, VOL_or_BND=ngs.BND))[0] for x in np.linspace(2, 3, 11) for y in (0.5, -0.5)]
        out[f"{family} maxh {maxh}"] = {"wss rel. error": float(np.abs(np.array(shear) + tau).max() / tau),
                                        "interface force_x / (-P_in 2R) - 1":
                                            surfaces.values()["interface.force_x"] / -10.0 - 1}
    return out


def womersley(fine: bool) -> dict:
    settings = (0.05, 0.005, 6) if fine else (0.1, 0.01, 3)
    return {scheme: dict(zip(("middle", "inflow"), inflow.womersley_errors(scheme, *settings))) for scheme in SCHEMES}


def supported(fine: bool) -> dict:
    k, w, modulus, p = 1000.0, support.WALL, support.MODULUS, support.P
    settings = (0.05, 0.01) if fine else (0.1, 0.02)
    out = {}
    for scheme in SCHEMES:
        inner, outer = support.displacements(scheme, k, 10.0, *settings)
        out[scheme] = {"inner / p(1/k + w/(λ+2μ)) - 1": inner / (p * (1 / k + w / modulus)) - 1,
                       "outer / (p/k) - 1": outer / (p / k) - 1}
    return out


if __name__ == "__main__":
    fine = "--fine" in sys.argv
    record = {"resistance": resistance_outlet(), "windkessel_order": windkessel_order(), "flux": discrete_flux(),
              "womersley": womersley(fine), "support": supported(fine), "two_materials": two_materials(),
              "poiseuille_wss": poiseuille_wss(), "reflection": reflections(fine)}
    print(json.dumps(record, indent=1))
