"""The harmonic response (`fsivsp.frequency.harmonic`) against the time domain and an exact solution.

- Crank–Nicolson is the Cayley transform of the semi-discrete system: its periodic state under data × cos(ωt − φ)
  is *exactly* the harmonic solution at s_CN = (2i/Δt) tan(ωΔt/2). Started on that orbit, the scheme stays on it to
  round-off: a sharp check of the operator, the amplitudes, the phases and the lifts, in a few steps.
- The issue's claim: `fsivsp harmonic` equals the periodic state of `fsivsp run` with the same data × cos(2πft) at
  every probe to 1 %, CN with Δt = T/100 after the start-up has decayed (the difference is CN's frequency warping,
  (ωΔt)²/12 amplified near a resonance).
- The shear layers (`experiments.shear_layers`): v̂ converges to the exact response at the rates of the element.
"""
import math

import ngsolve as ngs
import numpy as np
import pytest
from support.channels import mean_over, rigid, tube
from support.frequency import LID, TUBE, harmonic_case, time_domain_case

import fsivsp
from fsivsp.app.frequency import case_spaces, harmonic_data
from fsivsp.app.loop import build_scheme
from fsivsp.config.frequency import load_harmonic_case
from fsivsp.config.production import load_run_case
from fsivsp.experiments.shear_layers import ShearLayers
from fsivsp.fem.spaces import build_spaces
from fsivsp.frequency.harmonic import Amplitudes, HarmonicData, respond
from fsivsp.geometry import build_geometry, refined
from fsivsp.model.data import Windkessel, resistance
from fsivsp.model.expressions import parse_vector
from fsivsp.model.fields import Field
from fsivsp.model.materials import Materials
from fsivsp.runtime.threads import using


def harmonic_at(case, s: complex):
    """The case's (loaded `HarmonicCase`) harmonic solution at ``s``."""
    spaces, conditions = case_spaces(case, complex=True)
    return respond(spaces, case.materials, Amplitudes(spaces, harmonic_data(case, conditions)), s)


#: The tube with an RCR outlet (R_d C ω = 4 at f = 0.8) and its wall on tissue support instead of free.
TUBE_CONDITIONS = TUBE.replace('[boundary.solid_wall]\ntraction = ["0", "0"]',
                               "[boundary.solid_wall]\nsupport = { stiffness = 50.0, damping = 0.5 }") + """
[boundary.outflow]
windkessel = { proximal = 0.5, capacitance = 0.4, distal = 2.0 }
"""


@pytest.mark.parametrize("text, frequency", [(LID, 1.48), (TUBE, 0.8), (TUBE_CONDITIONS, 0.8)],
                         ids=["lid-mini-resonance", "tube-th1", "tube-th1-windkessel-support"])
def test_crank_nicolson_orbit_is_the_harmonic_solution_at_its_image(text, frequency):
    """Started from Re(v̂, û = v̂/s_CN) of the harmonic solution at s_CN (and an RCR outlet's P_c from
    P̂_c = R_d Q̂/(1 + s_CN R_d C)), 60 Crank–Nicolson steps of the run case with the same data × cos(2πft − φ) are
    Re(v̂ zⁿ), z = e^{iωΔt}, to 1e-10 of max |v̂| (measured 1e-13; with s = iω instead, 2e-3 near the resonance: the
    test tells the two apart). With outlets and support: the harmonic response's Z(s) and (c + k/s) are the time
    domain's at CN's s."""
    dt = 1 / (40 * frequency)
    omega = 2 * math.pi * frequency
    s_cn = 2j / dt * math.tan(omega * dt / 2)
    with using(1):
        case = load_harmonic_case(harmonic_case(text, [frequency]))
        errors = {}
        for name, s in (("s_CN", s_cn), ("iω", 1j * omega)):
            response = harmonic_at(case, s)
            scheme = build_scheme(load_run_case(time_domain_case(text, frequency, T=60 * dt, dt=dt)))
            state = response.state.vec.FV().NumPy()
            velocity = slice(0, scheme.spaces.velocity.ndof)
            scheme.state.vec.FV().NumPy()[:] = state.real
            scheme.carried.vec.FV().NumPy()[velocity] = (state[velocity] / s).real
            scheme.solution.vec.data = scheme.state.vec
            assert len(scheme.outlets) == (text is TUBE_CONDITIONS) and response.residual < 1e-12
            for outlet, c in zip(scheme.outlets, scheme.flux_vectors):
                flow = complex(np.dot(c.FV().NumPy(), state))
                pc = outlet.model.distal / (1 + s * outlet.model.distal * outlet.model.capacitance) * flow
                outlet.state[:] = (pc.real, pc.real, flow.real)
            scheme.march(60)
            expected = (state[velocity] * np.exp(1j * omega * scheme.time)).real
            errors[name] = np.abs(scheme.state.vec.FV().NumPy()[velocity] - expected).max() / np.abs(state).max()
    assert errors["s_CN"] < 1e-10 and errors["iω"] > 1e-4, errors


def harmonic_amplitudes(out) -> dict[str, complex]:
    """harmonic.csv's single row as complex amplitudes â = |â| e^{−iφ}, by probes.csv's column names."""
    table = np.genfromtxt(out / "harmonic.csv", delimiter=",", names=True)
    return {name.removesuffix("_amp"): complex(table[name] * np.exp(-1j * np.radians(table[name[:-4] + "_phase"])))
            for name in table.dtype.names if name.endswith("_amp")}


def periodic_amplitudes(out, frequency: float, start: float) -> dict[str, complex]:
    """probes.csv's columns from ``start`` on fitted by a cos ωt + b sin ωt, as â = a − ib."""
    table = np.genfromtxt(out / "probes.csv", delimiter=",", names=True)
    last = table["time"] > start
    omega, times = 2 * math.pi * frequency, table["time"][last]
    basis = np.column_stack([np.cos(omega * times), np.sin(omega * times)])
    names = [name for name in table.dtype.names if name not in ("step", "time")]
    (a, b), *_ = np.linalg.lstsq(basis, np.nan_to_num(np.column_stack([table[n][last] for n in names])), rcond=None)
    return dict(zip(names, a - 1j * b))


def test_harmonic_equals_the_periodic_state_of_a_run(tmp_path):
    """`fsivsp.harmonic` and the periodic state of `fsivsp.run` (CN, Δt = T/100, the data ramped in over 2 periods,
    14 periods) at f = 0.5, fitted over the last period: every probe's velocity components to 1 % of the probe's
    largest velocity amplitude, its pressure to 1 % of its own (measured ≤ 6.2e-4 and ≤ 1.0e-3: the frequency
    warping of Crank–Nicolson, (ωΔt)²/12 = 3.3e-4, amplified by the modes nearby)."""
    frequency, periods = 0.5, 14
    harmonic = fsivsp.harmonic(harmonic_case(LID, [frequency]), out=tmp_path / "harmonic", quiet=True)
    assert harmonic["status"] == "completed" and harmonic["solves"][0]["residual"] < 1e-12
    dt = 1 / (100 * frequency)
    run = time_domain_case(LID, frequency, T=periods / frequency, dt=dt, ramp=2 / frequency)
    assert fsivsp.run(run, out=tmp_path / "run", quiet=True)["status"] == "completed"
    expected = harmonic_amplitudes(tmp_path / "harmonic")
    found = periodic_amplitudes(tmp_path / "run", frequency, (periods - 1) / frequency + dt / 2)
    assert set(expected) == set(found)
    for probe in range(4):
        velocity = [f"p{probe}_v1", f"p{probe}_v2"]
        scale = max(abs(expected[name]) for name in velocity)
        for name in velocity:
            assert abs(found[name] - expected[name]) < 0.01 * scale, (name, found[name], expected[name])
        pressure = expected[f"p{probe}_p"]
        assert abs(found[f"p{probe}_p"] - pressure) < 0.01 * abs(pressure) if probe < 3 else np.isnan(pressure)


@pytest.mark.parametrize("family, order, rate", [("mini", 1, 2), ("taylor_hood", 1, 3), ("taylor_hood", 2, 4)])
def test_shear_layers_converge_to_the_exact_response(family, order, rate):
    """The layers (h_F = h_S = 0.5, period 0.25, `fluid_over_solid` periodic in x) driven by the top wall with
    (1, 0) e^{iωt} at the first shear mode's frequency 0.38 (s₁ = −0.482 + 2.385i): the relative L²(Ω) error of v̂
    against the exact (v_x(y), 0) (`ShearLayers.driven_coefficient`) falls at h^{k+2} (MINI: h²) over levels 0–2 on
    periodic complex spaces (measured rates 1.99/2.00, 3.05/3.03, 4.05/4.03)."""
    materials = Materials(1.0, 1.0, 0.1, 2.0, 1.0)
    s = 2j * math.pi * 0.38
    exact = ShearLayers(1.0, 1.0, 0.1, 1.0, 0.5, 0.5).driven_coefficient(s)
    coarse = build_geometry("fluid_over_solid", 2, 0.125, width=0.25, periodic="x")
    data = HarmonicData(2, boundary_velocity={"fluid_wall": Field(parse_vector(["1", "0"], "wall", 2)),
                                              "solid_wall": Field([0, 0])})
    errors = []
    with using(1):
        for level in range(3):
            mesh = refined(coarse, level)
            spaces = build_spaces(mesh, family, order, "fluid_wall|solid_wall", complex=True)
            velocity = respond(spaces, materials, Amplitudes(spaces, data), s).velocity
            errors.append(math.sqrt(squared(velocity - exact, mesh) / squared(exact, mesh)))
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert rates.min() > rate - 0.15, (errors, rates)


def squared(field, mesh) -> float:
    """∫_Ω |field|² of a complex vector field."""
    return ngs.Integrate(ngs.InnerProduct(field.real, field.real) + ngs.InnerProduct(field.imag, field.imag), mesh,
                         order=12)


@pytest.mark.parametrize("outlet, frequency", [(resistance(50.0), 0.01), (Windkessel(10.0, 0.02, 50.0), 0.5 / math.pi)],
                         ids=["resistance", "windkessel"])
def test_outlet_pressure_is_the_impedance_times_the_flow(outlet, frequency):
    """A rigid channel (`support.channels`, ν = 0.1) driven by an inflow pressure amplitude 100 with a lumped outlet:
    the outflow's mean pressure p̂ is Z(s) Q̂ to 1 % in modulus and 0.01 rad in phase (measured +0.144 % and
    +0.135 %, phases 2e-6 and 1e-3 rad; the time domain's R Q to +0.14 %, the stress-form outlet's corner:
    docs/validation.md), a resistance at f = 0.01 and an RCR of |Z| = 43
    at ωR_dC = 1 (Z's phase −0.62 rad; the corner's error is absolute, ∝ νQ: with |Z| = 4.3 it was 1.3 %); at
    f = 0.01 the flow is Poiseuille's quasi-steady P_in/(R + R_Poiseuille) to 1 %."""
    mesh = tube(2, 0.1, 2.0)
    spaces = build_spaces(mesh, "taylor_hood", 1, "solid_ends|solid_wall", complex=True)
    data = HarmonicData(2, boundary_velocity={"solid_ends|solid_wall": Field([0, 0])},
                        boundary_traction={"inflow": Field([100, 0])}, outlets={"outflow": outlet})
    s = 2j * math.pi * frequency
    response = respond(spaces, rigid(0.1), Amplitudes(spaces, data), s)
    assert response.residual < 1e-12
    normal = ngs.specialcf.normal(2)
    flow = ngs.Integrate(response.velocity * normal, mesh, ngs.BND, definedon=mesh.Boundaries("outflow"))
    ratio = mean_over(mesh, response.pressure, "outflow") / (outlet.impedance(s) * flow)
    assert abs(abs(ratio) - 1) < 0.01 and abs(np.angle(ratio)) < 0.01, ratio
    if outlet.capacitance == 0:
        assert abs(flow) == pytest.approx(100 / (outlet.proximal + 3 * 0.1 * 2.0 / (2 * 0.5**3)), rel=0.01)
