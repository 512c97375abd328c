"""What a step costs, in products with the step matrix: the unit that does not depend on the machine's speed, only on
how the solve uses it (a direct solve's substitutions, an FGMRES iteration's product, preconditioner and
orthogonalisation). ``fsivsp run`` records it in summary.json (`step_cost`); benchmarks/scale.py against N.

    clock = StepClock()
    with clock:
        scheme.step()
    record = step_cost(scheme, clock)   # {"iterations_mean": …, "step_seconds": …, "matvec_ratio": …}
"""
from __future__ import annotations

import statistics
import time

from ..runtime.threads import current as current_threads

#: Products timed for one `product_seconds` (their median: robust to a scheduler's tick on a shared machine).
PRODUCT_REPEATS = 5
#: On more than one thread, untimed products for this long come first: right after `march` (which stops the
#: TaskManager for its overlapped loop and starts it again) NGSolve's products are slow for a while. The 3D fluid
#: ball, two threads: level 3 (65 130 unknowns) 8.0 ms a product for the first 80 ms, then 1.2–1.3 ms; level 4
#: (535 830) 18 → 11 ms over 90 ms. On one thread no such transient (2.3 ms from the first product on level 3).
SETTLE_SECONDS = 0.2


def product_seconds(matrix, repeats: int = PRODUCT_REPEATS) -> float:
    """The median wall time of ``repeats`` products y = A x with ``matrix`` (x = 1; NGSolve's, on the run's
    threads, after `SETTLE_SECONDS` of untimed ones on more than one; a distributed matrix: this rank's part, the
    products of the ranks' local matrices)."""
    x, y = matrix.CreateColVector(), matrix.CreateColVector()
    x[:] = 1.0
    y.data = matrix * x   # the first touches the vectors' pages: not timed
    settled = time.perf_counter() + (SETTLE_SECONDS if current_threads() > 1 else 0.0)
    while time.perf_counter() < settled:
        y.data = matrix * x
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        y.data = matrix * x
        times.append(time.perf_counter() - start)
    return statistics.median(times)


class StepClock:
    """The wall time of the steps taken in its ``with`` blocks (one step each): ``seconds`` in ``steps``."""

    def __init__(self):
        self.seconds, self.steps, self._start = 0.0, 0, 0.0

    def __enter__(self) -> StepClock:
        self._start = time.perf_counter()
        return self

    def __exit__(self, *exc) -> None:
        if exc[0] is None:
            self.seconds += time.perf_counter() - self._start
            self.steps += 1


def step_cost(scheme, clock: StepClock, comm=None) -> dict:
    """The cost of ``scheme``'s steps timed by ``clock``: ``iterations_mean`` (the solver's mean iterations per solve,
    None for a direct solver), ``step_seconds`` (the mean wall time of a step, None before the first one),
    ``product_seconds`` (`product_seconds` of the step matrix, now) and ``matvec_ratio`` = step_seconds ÷
    product_seconds, with ``timed_steps``. Under mpirun (``comm``: the mesh's) every rank must call it; the times
    are the slowest rank's."""
    product = product_seconds(scheme.step_matrix)
    step = clock.seconds / clock.steps if clock.steps else None
    if comm is not None and comm.size > 1:
        product = comm.Max(product)
        step = comm.Max(step) if step is not None else None
    iterations = scheme.solver.statistics().get("iterations")
    return {"iterations_mean": iterations["mean"] if iterations else None,
            "timed_steps": clock.steps, "step_seconds": step, "product_seconds": product,
            "matvec_ratio": step / product if step is not None and product > 0 else None}
