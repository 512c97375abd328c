"""``[geometry] periodic``: the identified sides survive refinement (netgen's ``Mesh.Copy`` drops them), the spaces
on such a mesh are periodic, and PARDISO factorises their step matrix."""
import numpy as np
import pytest

from fsivsp.fem import forms
from fsivsp.fem.spaces import build_spaces
from fsivsp.geometry import GeometryError, build_geometry, is_periodic, refined
from fsivsp.model.materials import Materials
from fsivsp.solvers import compact, factorise


def identified_pairs(mesh) -> np.ndarray:
    """The coordinates of every identified pair of points, (pairs, 2, 3)."""
    ngmesh = mesh.ngmesh
    return np.array([[ngmesh[first].p, ngmesh[second].p] for first, second, _ in ngmesh.GetIdentifications()])


@pytest.mark.parametrize("kind, dim, axes, sizes", [
    ("fluid_over_solid", 2, "x", {"width": 0.25}), ("elastic_tube", 2, "x", {"length": 1.0}),
    ("fluid_over_solid", 3, "xy", {"width": 0.5})], ids=["layers-2d", "tube-2d", "layers-3d-xy"])
@pytest.mark.parametrize("project", [True, False], ids=["projected", "geometry-free"])
def test_refinement_keeps_the_identification(kind, dim, axes, sizes, project):
    """Every identified pair is a translation by the period along one axis, before and after a refinement, which
    identifies the new points of the identified edges too."""
    mesh = build_geometry(kind, dim, 0.25 if dim == 3 else 0.1, periodic=axes, **sizes)
    fine = refined(mesh, 1, project)
    assert is_periodic(mesh) and is_periodic(fine)
    period = next(iter(sizes.values()))
    for m in (mesh, fine):
        shift = np.abs(np.diff(identified_pairs(m), axis=1)[:, 0])
        along = np.argmax(shift, axis=1)
        assert set(along) == {"xyz".index(a) for a in axes}
        assert np.allclose(shift.max(axis=1), period) and np.allclose(np.sort(shift, axis=1)[:, :-1], 0)
    if dim == 2:  # a side is one polyline: its n + 1 points become 2n + 1
        assert len(fine.ngmesh.GetIdentifications()) == 2 * len(mesh.ngmesh.GetIdentifications()) - 1


def test_spaces_on_a_periodic_mesh_glue_the_sides():
    """V_h and Q_h are NGSolve's periodic spaces on the layers; the step matrix factorises with the first method
    (PARDISO: its pattern, one-sided by round-off, made symmetric, `solvers.compact`), no other method taken."""
    mesh = build_geometry("fluid_over_solid", 2, 0.125, width=0.25, periodic="x")
    plain = build_geometry("fluid_over_solid", 2, 0.125, width=0.25)
    spaces = build_spaces(mesh, "taylor_hood", 1, "fluid_wall|solid_wall")
    assert spaces.periodic and not build_spaces(plain, "taylor_hood", 1, "fluid_wall|solid_wall").periodic
    matrix = compact(forms.step_matrix(spaces, Materials(1, 1, 0.1, 2, 1), 0.005).Assemble().mat, symmetric=True)
    solver = factorise(matrix, spaces.mixed.FreeDofs())
    assert solver.fallback is None and solver.residual < 1e-12


def test_periodic_is_checked():
    with pytest.raises(GeometryError, match=r"^geometry.periodic: expected \"x\" \(the axes"):
        build_geometry("fluid_over_solid", 2, 0.1, periodic="xy")
    with pytest.raises(GeometryError, match="unknown parameter for kind 'fluid_in_solid'"):
        build_geometry("fluid_in_solid", 2, 0.1, periodic="x")
