"""Flow-rate inflows (`fem.inflow`): the sections they need, the analytic profiles, the discrete flux equal to Q(t) at
every step with each profile, and the Womersley flow of a rigid channel against the analytic one."""
import numpy as np
import pytest
from scipy import special
from support.channels import at_rest, channel_scheme, history, rigid, tube

from fsivsp.geometry import fluid_in_solid, fluid_over_solid
from fsivsp.geometry.sections import SectionError, detect_section
from fsivsp.model.data import PROFILES, FlowRate
from fsivsp.model.expressions import parse
from fsivsp.model.womersley import profile, womersley_shape

RADIUS = 0.5
WAVE = "2*sin(2*pi*t) + 0.5*(1 - cos(4*pi*t))"  # Q(0) = 0, peak 2.5
#: A cardiac-like table over a period of 1, linear in between: not band-limited, so a Womersley series of 10
#: harmonics misses it by 0.2 and the rest rides on the parabola.
TABLE = ((0.0, 0.1, 0.2, 0.3, 0.35, 0.45, 0.6, 1.0), (0.0, 1.0, 2.5, 1.5, -0.2, 0.4, 0.2, 0.0))


def test_sections_accept_segments_and_disks_and_refuse_others():
    tube2, tube3 = tube(2, 0.1, 2.0), tube(3, 0.5, 1.0)
    inflow = detect_section(tube2, "inflow")
    assert inflow.radius == pytest.approx(RADIUS, rel=1e-12) and np.allclose(inflow.normal, [-1, 0])
    assert np.allclose(inflow.centre, [0, 0], atol=1e-12) and inflow.measure == pytest.approx(1.0)
    disk = detect_section(tube3, "outflow")
    assert disk.radius == pytest.approx(RADIUS, rel=1e-9) and np.allclose(disk.normal, [1, 0, 0])
    assert np.allclose(disk.centre, [1, 0, 0], atol=1e-9)
    refused = [(tube2, "interface", "not a straight segment"), (fluid_in_solid(2, 0.1), "interface", "not a straight"),
               (tube3, "solid_ends", "not a flat disk"), (fluid_over_solid(3, 0.5), "interface", "not a flat disk")]
    for mesh, name, message in refused:
        with pytest.raises(SectionError, match=rf"^boundary.{name}: {message}[^\n]*$"):
            detect_section(mesh, name)


@pytest.mark.parametrize("dim", [2, 3])
def test_womersley_profiles_have_unit_flux_and_solve_the_ode(dim):
    """W_ω has unit flux, vanishes at the wall and solves iωρW − ν(W'' + (d − 2)W'/r) = const (finite differences);
    in 3D it is the textbook J₀(i^{3/2} α r/R) profile (measured: the constant varies by 2e-8, textbook 8e-9)."""
    rho, nu = 1.0, 0.1
    r = np.linspace(0, RADIUS, 20001)
    h = r[1] - r[0]
    for omega in (0.0, 2 * np.pi, 40 * np.pi):
        w = womersley_shape(r, RADIUS, omega, rho, nu, dim)
        weight = 2 * np.ones_like(r) if dim == 2 else 2 * np.pi * r
        assert abs(np.trapz(weight * w, r) - 1) < 1e-7 and abs(w[-1]) < 1e-12
        laplacian = (w[2:] - 2 * w[1:-1] + w[:-2]) / h**2 + (dim - 2) / r[1:-1] * (w[2:] - w[:-2]) / (2 * h)
        constant = (1j * omega * rho * w[1:-1] - nu * laplacian)[100:-100]
        assert np.ptp(np.abs(constant)) < 1e-6 * np.abs(constant).mean()
        if dim == 3 and omega:
            alpha = RADIUS * np.sqrt(omega * rho / nu)
            j0 = 1 - special.jv(0, 1j**1.5 * alpha * r / RADIUS) / special.jv(0, 1j**1.5 * alpha)
            assert np.abs(j0 / np.trapz(2 * np.pi * r * j0, r) - w).max() < 1e-7 * np.abs(w).max()


@pytest.mark.parametrize("dim, family", [(2, "taylor_hood"), (2, "mini"), (3, "taylor_hood")])
def test_discrete_inflow_is_the_flow_at_every_step(dim, family):
    """−∫_Γin v_h·n = Q(tₙ) to 1e-8 of max |Q| at every step (measured ≤ 4.4e-16), for each profile, and for a
    tabulated, not band-limited Q with the Womersley profile; plug and parabolic profiles differ at the rim."""
    flows = [(profile, parse(WAVE, "flow")) for profile in PROFILES] + [("womersley", TABLE)]
    shapes = {}
    for name, flow in flows:
        rate = FlowRate(flow, name, 1.0, 10)
        data = at_rest(dim, velocity={"solid_ends|solid_wall": [0] * dim}, boundary_flow={"inflow": rate})
        run = channel_scheme(data, rigid(0.1), 0.05, "bdf2", maxh=0.1 if dim == 2 else 0.5,
                             length=2.0 if dim == 2 else 1.0, dirichlet="inflow|solid_ends|solid_wall", family=family,
                             dim=dim)
        inflow, q = run.inflows["inflow"], rate.function()
        record = history(run, 6, flux=lambda s, inward=inflow.inward: inward.InnerProduct(s.state.vec))
        errors = np.abs(record["flux"] - [q(t) for t in record["time"]])
        assert errors.max() < 1e-8 * 2.5, (name, errors)
        shapes[name] = inflow.values.vectors[0].FV().NumPy().copy()
    assert np.abs(shapes["plug"] - shapes["parabolic"]).max() > 0.1 * np.abs(shapes["parabolic"]).max()


def womersley_errors(scheme: str, maxh: float, dt: float, periods: int) -> tuple[float, float]:
    """Max |u_h − u| across x = L/2 over the last period, over the peak, in a rigid channel (R = 0.5, L = 3,
    α = 4 at the base frequency) driven by Q(t) of `WAVE` with the Womersley profile; and the same at the inflow."""
    alpha, rho, length = 4.0, 1.0, 3.0
    nu = 2 * np.pi * rho * RADIUS**2 / alpha**2
    rate = FlowRate(parse(WAVE, "flow"), "womersley", 1.0, 10)
    data = at_rest(velocity={"solid_ends|solid_wall": [0, 0]}, boundary_flow={"inflow": rate})
    run = channel_scheme(data, rigid(nu, rho), dt, scheme, maxh=maxh, length=length,
                         dirichlet="inflow|solid_ends|solid_wall")
    mesh, inflow, ys = run.spaces.mesh, run.inflows["inflow"], np.linspace(-RADIUS, RADIUS, 41)
    steps = round(1 / dt)
    errors, peak = np.zeros(2), 0.0

    def observe(s):
        nonlocal peak
        if s.n > (periods - 1) * steps:
            exact = profile(np.abs(ys), s.time, inflow.coefficients, 1.0, RADIUS, rho, nu, 2)
            for k, x in enumerate((length / 2, 0.0)):
                errors[k] = max(errors[k], np.abs([s.velocity(mesh(x, y))[0] - e for y, e in zip(ys, exact)]).max())
            peak = max(peak, np.abs(exact).max())

    run.march(periods * steps, observe)
    return tuple(errors / peak)


@pytest.mark.parametrize("scheme", ["backward_euler", "crank_nicolson", "bdf2"])
def test_womersley_flow_of_a_rigid_channel(scheme):
    """After the start-up (one period from rest with Q(0) = 0), the axial velocity across the middle of the channel
    is the analytic Womersley profile to 2 % of its peak (measured in the 3rd period at maxh 0.1, Δt 0.01: 0.55 %,
    0.46 %, 0.22 %), and the imposed profile at the inflow to 0.5 % (0.31 %: P2 interpolation)."""
    middle, inlet = womersley_errors(scheme, 0.1, 0.01, 3)
    assert middle < 0.02 and inlet < 0.005, (middle, inlet)


@pytest.mark.slow
@pytest.mark.parametrize("scheme", ["backward_euler", "crank_nicolson", "bdf2"])
def test_womersley_flow_of_a_rigid_channel_fine(scheme):
    """maxh 0.05, Δt 0.005, the 6th period (measured 0.27 %, 0.063 %, 0.022 %)."""
    middle, _ = womersley_errors(scheme, 0.05, 0.005, 6)
    assert middle < 0.005, middle
