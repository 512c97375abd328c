"""The time loop of a `Scheme` (`Scheme.march`): its steps one after the other, or from `MARCH_THREAD_MIN_DOFS`
unknowns on with each solve overlapping the rest of the step before in a second thread."""
from __future__ import annotations

import contextlib
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Protocol

import ngsolve as ngs

from ..runtime.threads import current as current_threads
from ..runtime.threads import sequential


class Scheme(Protocol):
    """What the loop drives (`scheme.Scheme`): its state and solver, and the pieces of a step."""

    n: int
    dt: float
    tau: float
    time_scheme: Any
    solver: Any
    spaces: Any
    state: ngs.GridFunction
    warm: Any    # `warmstart.MinimalResidualStart`

    def step(self) -> None: ...

    def solve(self, rhs: ngs.BaseVector, boundary: ngs.BaseVector, out: ngs.BaseVector, n: int) -> None: ...

    def right_hand_side(self, current, n: int, out: ngs.BaseVector, boundary: ngs.BaseVector) -> None: ...

    def lagged_right_hand_side(self, out: ngs.BaseVector, boundary: ngs.BaseVector, n: int, work,
                               product: ngs.BaseVector | None = None) -> None: ...

    def add_lagged(self, out: ngs.BaseVector, velocity: ngs.BaseVector, n: int,
                   product: ngs.BaseVector | None = None) -> None: ...

    def accept(self, raw: ngs.BaseVector, n: int, current, observe) -> None: ...


#: From this many free unknowns on `march` overlaps each solve with the rest of the previous step in
#: a second thread; below, handing the work over (0.1–0.3 ms a step here) costs more than it saves
#: (benchmarks/scheme_timings.py, paper's experiment: 4 407 unknowns 0.97 ms a step against 0.92
#: sequentially, 17 931: 3.1 against 3.4 ms).
MARCH_THREAD_MIN_DOFS = 10_000


def march(scheme: Scheme, steps: int, observe: Callable[[Scheme], None] | None = None) -> None:
    """``steps`` steps of ``scheme``, calling ``observe(scheme)`` after each one with the scheme at that step.

    From `MARCH_THREAD_MIN_DOFS` free unknowns on, a second thread finishes step n while this one
    solves step n + 1: the stress update, ``observe`` (one call at a time and in order; the last in this
    thread) and the part of the next right-hand side without vⁿ⁺¹ (`Scheme.lagged_right_hand_side`).
    Between two solves only the product R vⁿ⁺¹ is left; each solve starts where `Scheme.step`'s would
    (`warmstart`), its solution recorded for the next start once the second thread has observed the step before (a
    checkpoint there holds the starts' history of that step). ``observe`` must not step
    the scheme. The results equal `Scheme.step` repeated up to round-off (7e-14 relative after 100 steps of the
    paper's experiment, level 4). On more threads (`threads.using`) the solve (PARDISO's substitutions, PETSc's
    FGMRES: neither runs under NGSolve's TaskManager) overlaps with the TaskManager stopped, so that the second core
    works beside the solve (the 3D ball's level 3, docs/solvers.md, "Threads"). A start step with another τ
    (BDF2's first) is taken by `step`."""
    while steps > 0 and scheme.time_scheme.start(scheme.n).tau(scheme.dt) != scheme.tau:
        _step(scheme, observe)
        steps -= 1
    if steps <= 0:
        return
    threaded = current_threads() > 1
    if not scheme.solver.overlap or scheme.spaces.free_dofs() < MARCH_THREAD_MIN_DOFS:
        for _ in range(steps):
            _step(scheme, observe)
        return
    with sequential() if threaded else contextlib.nullcontext():
        _overlapped(scheme, steps, observe)


def _step(scheme: Scheme, observe: Callable[[Scheme], None] | None) -> None:
    scheme.step()
    if observe is not None:
        observe(scheme)


def _overlapped(scheme: Scheme, steps: int, observe: Callable[[Scheme], None] | None) -> None:
    """``steps`` steps of the run's τ, each solve beside the rest of the step before (see `march`)."""
    vector = scheme.state.vec
    # step j solves with rhs[j % 2] and boundaries[j % 2] into solutions[j % 2]
    solutions, rhs, boundaries = ((vector.CreateVector(), vector.CreateVector()) for _ in range(3))
    work = (vector.CreateVector(), ngs.GridFunction(scheme.spaces.mixed))    # the second thread's
    first, time_scheme = scheme.n, scheme.time_scheme
    older = time_scheme.velocity(scheme.dt)[3]   # the coefficient of vⁿ⁻¹ in aⁿ⁺¹
    # R vʲ, formed for step j + 1's right-hand side, is kept for step j + 2's (BDF2's vⁿ⁻¹ term)
    products = (vector.CreateVector(), vector.CreateVector()) if older else None
    scheme.right_hand_side(time_scheme, first + 1, rhs[1], boundaries[1])

    def finish_previous(j: int) -> None:
        if j > 1:
            scheme.accept(solutions[(j - 1) % 2], first + j - 1, time_scheme, observe)
        if j < steps:
            scheme.lagged_right_hand_side(rhs[(j + 1) % 2], boundaries[(j + 1) % 2], first + j + 1, work,
                                          products[(j - 1) % 2] if products and j > 1 else None)

    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="fsivsp-march") as second:
        for j in range(1, steps + 1):
            finished = second.submit(finish_previous, j)
            scheme.solve(rhs[j % 2], boundaries[j % 2], solutions[j % 2], first + j - 1)
            finished.result()
            scheme.warm.record(solutions[j % 2])
            if j < steps:
                scheme.add_lagged(rhs[(j + 1) % 2], solutions[j % 2], first + j + 1,
                                  products[j % 2] if products else None)
    scheme.accept(solutions[steps % 2], first + steps, time_scheme, observe)
