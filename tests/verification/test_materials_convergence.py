"""A manufactured solution with two solid materials converges at the element's rates: the layers "solid" and
"plaque" of a CAD file under the fluid, the plaque with its own ρ_S, λ, μ (``[materials.plaque]``); the data carry
each region's force and the traction jumps on Γ and on the solid–solid interface (`ExactSolution.region_data`)."""
import pytest
from netgen.occ import Glue, MoveTo

from fsivsp.config.case import load_study_case
from fsivsp.experiments.study import study

EXACT = {"velocity": ["sin(pi*y)", "sin(pi*x)"], "pressure": "cos(pi*x)*cos(pi*y)",
         "displacement": ["x*y + (1 + t)*sin(pi*y)", "x**2/2 + (1 + t)*sin(pi*x)"]}


def layers(path):
    """(0, 1) × (0, 0.25) "solid", (0, 1) × (0.25, 0.5) "plaque", (0, 1) × (0.5, 1) "fluid", as a plane STEP file."""
    solid, plaque, fluid = (MoveTo(0, y).Rectangle(1, height).Face() for y, height in ((0, 0.25), (0.25, 0.25),
                                                                                      (0.5, 0.5)))
    solid.name, plaque.name, fluid.name = "solid", "plaque", "fluid"
    Glue([solid, plaque, fluid]).WriteStep(str(path))
    return path


def test_two_solid_materials_converge_at_taylor_hoods_rates(tmp_path):
    """Taylor–Hood k = 1, levels 0–2, backward Euler (exact in time: u is linear in t): every error's rate (76) is
    the element's 2 (measured 2.40, 2.34, 2.54, 2.19 for v₁, v₂, p, σ on the last level; without the solid–solid
    jump they stall near 0)."""
    case = load_study_case({
        "geometry": {"kind": "cad", "dim": 2, "maxh": 0.25, "path": str(layers(tmp_path / "layers.step")),
                     "regions": {"plaque": "solid"}},
        "materials": {"rho_fluid": 1.0, "rho_solid": 2.0, "nu": 0.5, "lam": 1.5, "mu": 0.75,
                      "plaque": {"rho_solid": 1.0, "lam": 12.0, "mu": 4.0}},
        "time": {"T": 0.1, "dt": 0.02},
        "discretisation": {"family": "taylor_hood", "order": 1},
        "exact": EXACT,
    })
    assert set(case.materials.regions) == {"plaque"}
    records = study(case, range(0, 3))
    last = records[-1]
    for name in ("v1", "v2", "p", "sigma"):
        assert last["rates"][name] > 1.8, (name, [r["errors"][name] for r in records])
    assert last["errors"]["sigma"] < 0.3 * records[0]["errors"]["sigma"]


def test_projected_initial_stress_needs_one_solid_material(tmp_path):
    case = {"geometry": {"kind": "cad", "dim": 2, "maxh": 0.5, "path": str(layers(tmp_path / "layers.step")),
                         "regions": {"plaque": "solid"}},
            "materials": {"rho_fluid": 1.0, "rho_solid": 2.0, "nu": 0.5, "lam": 1.5, "mu": 0.75,
                          "plaque": {"mu": 4.0}},
            "time": {"T": 0.1, "dt": 0.02}, "discretisation": {"initial_stress": "projection"}, "exact": EXACT}
    with pytest.raises(ValueError, match="^discretisation.initial_stress: \"projection\" is not supported"):
        load_study_case(case)
