"""The unit of a step's cost (`fsivsp.timestepping.cost.product_seconds`): timed after the threads settle."""
import time

import ngsolve as ngs
from netgen.geom2d import unit_square

from fsivsp.runtime import threads
from fsivsp.timestepping.cost import SETTLE_SECONDS, product_seconds


def _mass():
    mesh = ngs.Mesh(unit_square.GenerateMesh(maxh=0.1))
    space = ngs.H1(mesh, order=1)
    u, v = space.TnT()
    return ngs.BilinearForm(u * v * ngs.dx).Assemble().mat


def _seconds(count: int, matrix) -> tuple[float, float]:
    with threads.using(count):
        start = time.perf_counter()
        product = product_seconds(matrix)
        return time.perf_counter() - start, product


def test_products_are_timed_after_the_threads_settle():
    """On two threads `SETTLE_SECONDS` of untimed products come first (right after `march` they were 6× slower for
    80 ms on the fluid ball's level 3); on one thread none, so that small runs pay nothing."""
    matrix = _mass()
    two, product = _seconds(2, matrix)
    assert two >= SETTLE_SECONDS and 0 < product < SETTLE_SECONDS
    one, product = _seconds(1, matrix)
    assert one < SETTLE_SECONDS / 2 and product > 0
