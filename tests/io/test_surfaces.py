"""Surface quantities (`io.surfaces`) on steady Poiseuille flow in a rigid channel: flows, areas, mean pressures,
forces and the wall shear stress against the analytic ones."""
import ngsolve as ngs
import numpy as np
import pytest
from support.channels import at_rest, channel_scheme, rigid

from fsivsp.io.surfaces import Surfaces, SurfaceTable

RADIUS, LENGTH, NU, P_IN = 0.5, 5.0, 1.0, 10.0
NAMES = ["inflow", "outflow", "interface", "solid_wall"]


@pytest.fixture(scope="module")
def poiseuille():
    """A rigid channel (R = 0.5, L = 5, ν = 1) driven by an inflow pressure of 10 to steady state, Taylor–Hood k = 1
    (its P2 velocity holds the parabola exactly), and its `Surfaces`."""
    data = at_rest(velocity={"solid_ends|solid_wall": [0, 0]},
                   traction={"inflow": [f"{P_IN}*(1 - exp(-t**2/0.01))", 0]})
    run = channel_scheme(data, rigid(NU), 0.02, "backward_euler", length=LENGTH)
    run.march(60)
    return run, Surfaces(run, NAMES)


def test_flows_areas_pressures_and_forces(poiseuille):
    """Q_in = −Q_out, nothing through the rigid walls; the areas; the mean pressures at the inflow (P_in less the
    stress-form outlet's correction), at the outflow (its correction: 0.12) and on Γ (the middle: P_in/2); the force
    on the fluid through Γ, −P_in 2R to 0.1 % (measured 0.035 %); the table's columns."""
    run, surfaces = poiseuille
    values = surfaces.values()
    q = values["outflow.flow"]
    assert q > 0 and values["inflow.flow"] == pytest.approx(-q, rel=1e-10)
    assert abs(values["interface.flow"]) < 1e-10 * q and abs(values["solid_wall.flow"]) < 1e-10 * q
    assert [values[f"{name}.area"] for name in NAMES] == pytest.approx([1.0, 1.0, 10.0, 10.0], rel=1e-12)
    assert values["interface.pressure"] == pytest.approx(P_IN / 2, rel=1e-3)
    assert 0.95 * P_IN < values["inflow.pressure"] < P_IN and 0 < values["outflow.pressure"] < 0.05 * P_IN
    assert np.isnan(values["solid_wall.pressure"])
    assert values["interface.force_x"] == pytest.approx(-P_IN * 2 * RADIUS, rel=1e-3)
    assert abs(values["interface.force_y"]) < 1e-2 * abs(values["interface.force_x"])  # top and bottom cancel
    table = SurfaceTable(surfaces)
    table.record(run.time)
    assert table.columns[:5] == ["inflow.flow", "inflow.pressure", "inflow.area", "inflow.force_x", "inflow.force_y"]
    assert len(table.rows[0]) == 1 + 5 * len(NAMES)


def test_wall_shear_stress_of_poiseuille_flow(poiseuille):
    """τ_w = 3νQ/(2R²) along the developed middle of the channel, x ∈ [2, 3], on both walls (the x-component of
    σ_F n, n out of the fluid, is −τ_w): to 1e-4 (measured 1.0e-5); its normal part vanishes, the traction's normal
    part is −p."""
    run, surfaces = poiseuille
    traction, wss = surfaces.interface_fields()
    mesh = run.spaces.mesh
    tau = 3 * NU * surfaces.values()["outflow.flow"] / (2 * RADIUS**2)
    for y in (RADIUS, -RADIUS):
        for x in np.linspace(2.0, 3.0, 11):
            point = mesh(x, y, VOL_or_BND=ngs.BND)
            shear = np.array(wss(point))
            assert shear[0] == pytest.approx(-tau, rel=1e-4) and abs(shear[1]) < 1e-10 * tau
            assert traction(point)[1] * np.sign(y) == pytest.approx(-run.pressure(mesh(x, 0.0)), rel=1e-3)
