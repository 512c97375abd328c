"""Several materials (`geometry.Phases`, `forms.coefficients`): cell regions of any names, each fluid or solid with
its own constants; two solid regions of equal materials run as one, bit for bit."""
import numpy as np
import pytest
from support.channels import SCHEMES, at_rest, relabelled

from fsivsp.fem import forms
from fsivsp.fem.spaces import build_spaces
from fsivsp.geometry import GeometryError, elastic_tube, mesh_phases, without_geometry
from fsivsp.model.data import Support
from fsivsp.model.materials import Materials
from fsivsp.timestepping.scheme import Scheme

LENGTH = 2.0
MATERIALS = Materials.from_young(3e5, 0.3, rho_fluid=1.0, rho_solid=1.2, nu=0.035)


def pulse(mesh, materials: Materials, regions: dict | None = None, steps: int = 20):
    """20 BDF2 steps of an inflow pressure pulse through the tube, its outer wall supported: the state and the
    displacement."""
    spaces = build_spaces(mesh, "taylor_hood", 1, "solid_ends", mesh_phases(mesh, regions))
    data = at_rest(velocity={"solid_ends": [0, 0]}, traction={"inflow": ["1000*exp(-((t - 0.01)/0.005)**2)", 0]},
                   supports={"solid_wall": Support(1e3, 1.0)})
    run = Scheme(spaces, materials, data, 0.001, time_scheme=SCHEMES["bdf2"])
    run.march(steps)
    return run, run.state.vec.FV().NumPy().copy(), run.carried.vec.FV().NumPy().copy()


def test_two_equal_solid_regions_give_one_regions_run_bit_for_bit():
    """The tube's solid cells left of x = L/2 in a region "plaque" of the same materials (given or not), and the
    one-region run: the same bits in every step's state and displacement; another μ in the plaque changes them."""
    base = without_geometry(elastic_tube(2, 0.1, length=LENGTH))
    split = relabelled(base, LENGTH)
    assert {"plaque", "solid", "fluid"} == set(split.GetMaterials()) and split.ne == base.ne
    _, state, displacement = pulse(base, MATERIALS)
    for materials in (MATERIALS, MATERIALS.with_region("plaque", mu=MATERIALS.mu, lam=MATERIALS.lam)):
        run, other_state, other_displacement = pulse(split, materials, {"plaque": "solid"})
        assert run.coefficients is materials  # the floats, as for one region
        assert np.array_equal(state, other_state) and np.array_equal(displacement, other_displacement)
    run, stiffer, _ = pulse(split, MATERIALS.with_region("plaque", mu=2 * MATERIALS.mu), {"plaque": "solid"})
    assert not isinstance(run.coefficients.mu, float)
    assert np.abs(stiffer - state).max() > 1e-3 * np.abs(state).max()


def test_region_coefficients():
    """`forms.coefficients`: each constant that differs between regions is region-wise, the others stay numbers;
    ρ is ρ_F or ρ_S by region."""
    mesh = relabelled(without_geometry(elastic_tube(2, 0.25, length=LENGTH)), LENGTH)
    spaces = build_spaces(mesh, "taylor_hood", 1, "solid_ends", mesh_phases(mesh, {"plaque": "solid"}))
    materials = MATERIALS.with_region("plaque", rho_solid=5.0)
    values = forms.coefficients(materials, spaces)
    assert values.mu == MATERIALS.mu and values.nu == MATERIALS.nu and not isinstance(values.rho_solid, float)
    rho = forms.density(values, spaces)
    assert rho(mesh(0.5, 0.55)) == pytest.approx(5.0) and rho(mesh(1.5, 0.55)) == pytest.approx(1.2)
    assert rho(mesh(0.5, 0.0)) == pytest.approx(1.0)


def test_phases_of_a_mesh():
    mesh = relabelled(without_geometry(elastic_tube(2, 0.25, length=LENGTH)), LENGTH, "plaque")
    phases = mesh_phases(mesh, {"plaque": "solid"})
    assert phases.fluid == ("fluid",) and set(phases.solid) == {"solid", "plaque"}
    assert phases.pattern("solid") in ("solid|plaque", "plaque|solid")
    for regions, message in (({}, "volume region 'plaque' is neither 'fluid' nor 'solid'"),
                             ({"wall": "solid"}, "geometry.regions.wall: no cell region of that name"),
                             ({"plaque": "bone"}, "geometry.regions.plaque: expected 'fluid' or 'solid'")):
        with pytest.raises(GeometryError, match=message):
            mesh_phases(mesh, regions)
