"""The MINI spaces of Section 5.2.1: bubbles on fluid cells only, so that condition (18) holds."""
import ngsolve as ngs
import numpy as np

from fsivsp.fem import forms
from fsivsp.fem.spaces import Spaces, build_spaces
from fsivsp.geometry import FLUID, SOLID, region_counts
from fsivsp.model.materials import Materials


def random_velocity(spaces, seed=0):
    gf = ngs.GridFunction(spaces.velocity)
    gf.vec.FV().NumPy()[:] = np.random.default_rng(seed).standard_normal(len(gf.vec))
    return gf


def stress_update_defect(spaces, mat):
    """‖Π_S(λ div v I + 2μ ε(v)) − (λ div v I + 2μ ε(v))‖_{L²(Ω_S)} for a random v ∈ V_h."""
    v = random_velocity(spaces)
    x = ngs.GridFunction(spaces.mixed)
    x.components[0].vec.data = v.vec
    rate = forms.stress_rate(spaces, mat).Assemble().mat
    mass = forms.stress_mass(spaces).Assemble().mat
    sigma = ngs.GridFunction(spaces.stress)
    sigma.vec.data = mass.Inverse(spaces.stress.FreeDofs()) * (rate * x.vec)
    exact = forms.elastic_stress(v, mat, spaces.mesh.dim)
    diff = sigma - exact
    return np.sqrt(ngs.Integrate(ngs.InnerProduct(diff, diff), spaces.mesh, definedon=spaces.mesh.Materials(SOLID))), \
        np.sqrt(ngs.Integrate(ngs.InnerProduct(exact, exact), spaces.mesh, definedon=spaces.mesh.Materials(SOLID)))


def test_mini_dof_count(paper_meshes):
    for mesh in paper_meshes:
        spaces = build_spaces(mesh, "mini")
        counts = region_counts(mesh)
        assert spaces.velocity.ndof == 2 * (mesh.nv + counts["fluid_cells"])
        assert sum(spaces.pressure.FreeDofs()) == counts["fluid_vertices"]
        assert spaces.stress.ndof == 3 * (mesh.ne - counts["fluid_cells"])


def test_solid_cells_carry_no_bubble(paper_meshes):
    mesh = paper_meshes[0]
    spaces = build_spaces(mesh, "mini")
    for el in mesh.Elements(ngs.VOL):
        ndofs = len(spaces.velocity.GetDofNrs(el))
        assert ndofs == (2 * 4 if el.mat == FLUID else 2 * 3)


def test_stress_update_is_exact_with_mini(paper_meshes):
    """ε(V_h|_S) ⊆ S_h (18): the projected stress rate equals the pointwise one."""
    defect, size = stress_update_defect(build_spaces(paper_meshes[1], "mini"), Materials())
    assert defect < 1e-12 * size


def test_bubbles_in_the_solid_break_condition_18(paper_meshes):
    """The same check fails when every triangle carries a bubble (so the test above can fail)."""
    mini = build_spaces(paper_meshes[1], "mini")
    everywhere = ngs.VectorH1(paper_meshes[1], order=1, dirichlet="solid_wall")
    everywhere.SetOrder(ngs.TRIG, 3)
    everywhere.Update()
    spaces = Spaces("mini", 1, everywhere, mini.pressure, mini.stress, everywhere * mini.pressure)
    defect, size = stress_update_defect(spaces, Materials())
    assert defect > 1e-3 * size
