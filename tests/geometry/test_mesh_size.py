"""h of a study record is the active mesh's (issue 27): it halves under uniform refinement."""
import math

import pytest

from fsivsp.experiments.study import max_edge_length
from fsivsp.geometry import fluid_over_solid, refined


@pytest.mark.parametrize("dim, maxh", [(2, 0.3), (3, 0.6)])
def test_h_halves_under_uniform_refinement(dim, maxh):
    """2D: exactly half per level. 3D: a refined tetrahedron's inner octahedron diagonal can be longer than
    half the parent's longest edge, so h falls by 0.5–0.75 on the first refinement, then by exactly half."""
    coarse = fluid_over_solid(dim, maxh)
    h = [max_edge_length(refined(coarse, level)) for level in range(3)]
    assert 0 < h[0] <= 2 * maxh
    assert math.isclose(h[2], h[1] / 2, rel_tol=1e-9), h
    assert 0.5 * h[0] * (1 - 1e-9) <= h[1] <= (0.5 if dim == 2 else 0.75) * h[0] * (1 + 1e-9), h
