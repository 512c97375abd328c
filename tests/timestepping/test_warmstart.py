"""The iterative solver's start 2xⁿ − xⁿ⁻¹ (`fsivsp.timestepping.warmstart`) in every time scheme, in `march`'s
overlapped path and across a checkpoint: the direct solver's states, fewer iterations than from xⁿ, a resumed run
bit for bit the uninterrupted one."""
import numpy as np
import pytest

from fsivsp.experiments.paper import paper_case
from fsivsp.experiments.study import discretise
from fsivsp.io.checkpoint import load_checkpoint, save_checkpoint
from fsivsp.solvers import petsc_available
from fsivsp.timestepping import marching, warmstart
from fsivsp.timestepping.schemes import BDF2, Theta, time_scheme

SCHEMES = ["backward_euler", "theta", "bdf2"]


def test_extrapolates_one_scheme_from_step_3_on():
    """x⁰ (initial data, the pressure perhaps unknown) is never extrapolated from, nor BDF2's Crank–Nicolson start."""
    assert [warmstart.extrapolates(Theta(), n) for n in range(4)] == [False, False, True, True]
    assert [warmstart.extrapolates(Theta(0.5), n) for n in range(4)] == [False, False, True, True]
    assert [warmstart.extrapolates(BDF2(), n) for n in range(5)] == [False, False, False, True, True]


needs_petsc = pytest.mark.skipif(petsc_available() is not None, reason=str(petsc_available()))


def paper(name: str, mesh, method: str = "petsc", tolerance: float = 1e-12):
    case = paper_case(1e-2, time_scheme=time_scheme(name)).with_solver(method=method, tolerance=tolerance)
    return discretise(case, mesh)[0]


def state(scheme) -> list[np.ndarray]:
    return [v.FV().NumPy().copy() for v in (scheme.state.vec, scheme.carried.vec)]


@needs_petsc
@pytest.mark.parametrize("name", SCHEMES)
@pytest.mark.parametrize("overlapped", [False, True], ids=["step", "march"])
def test_iterative_equals_direct(paper_meshes, monkeypatch, name, overlapped):
    """PETSc at its default tolerance (1e-12), started by extrapolation, gives the direct solver's (v, p) and u_h
    to 1e-6 relative after 8 steps (the solvers' agreement docs/solvers.md requires), stepped or by `march` with
    its second thread; the start differed from xⁿ (the extrapolation ran), and was not formed for the direct solver."""
    monkeypatch.setattr(marching, "MARCH_THREAD_MIN_DOFS", 0 if overlapped else 10**12)
    direct, iterative = paper(name, paper_meshes[1], "direct"), paper(name, paper_meshes[1])
    starts = []
    original = warmstart.Extrapolation.start

    def start(self, *args, **kwargs):
        out = original(self, *args, **kwargs)
        starts.append(out is self.guess)
        return out
    monkeypatch.setattr(warmstart.Extrapolation, "start", start)
    direct.march(8)
    iterative.march(8)
    assert any(starts) and iterative.warm.enabled and not direct.warm.enabled   # a factorisation takes no start
    for mine, theirs in zip(state(iterative), state(direct)):
        assert np.abs(mine - theirs).max() <= 1e-6 * np.abs(theirs).max()


@needs_petsc
@pytest.mark.parametrize("name", SCHEMES)
def test_fewer_iterations_than_from_the_last_solution(paper_meshes, monkeypatch, name):
    """The paper's level 2, 20 steps, tolerance 1e-8: fewer FGMRES iterations in all than from xⁿ (exact counts;
    measured from xⁿ / extrapolated: steps 3–20 backward Euler 5.61 / 3.67, θ = 1/2 5.50 / 5.22; BDF2 steps 4–20
    5.06 / 4.00), the same in the steps before the extrapolation starts."""
    counts = {}
    for mode in ("previous", "extrapolated"):
        if mode == "previous":
            monkeypatch.setattr(warmstart, "extrapolates", lambda time_scheme, n: False)
        else:
            monkeypatch.undo()
        scheme = paper(name, paper_meshes[2], tolerance=1e-8)
        scheme.march(20)
        counts[mode] = scheme.solver.iterations
    previous, extrapolated = counts["previous"], counts["extrapolated"]
    first = len(previous) - 18  # the solves of steps 1–2 (BDF2: its start's Richardson solves too)
    assert previous[:first] == extrapolated[:first]
    assert sum(extrapolated) < sum(previous), (previous, extrapolated)


@needs_petsc
@pytest.mark.parametrize("name", SCHEMES)
def test_resume_is_bit_identical(tmp_path, paper_meshes, name):
    """A checkpoint at step 4 (the start extrapolated since step 3) resumed in a fresh scheme: the same iteration
    counts and the same bits as the uninterrupted run at step 8."""
    whole = paper(name, paper_meshes[1], tolerance=1e-8)
    whole.march(4)
    path = save_checkpoint(tmp_path / "checkpoint_000004.npz", whole, {})
    whole.march(4)
    resumed = paper(name, paper_meshes[1], tolerance=1e-8)
    load_checkpoint(path, resumed)
    resumed.march(4)
    assert resumed.solver.iterations == whole.solver.iterations[-4:]
    assert resumed.n == whole.n == 8
    for mine, theirs in zip(state(resumed) + [resumed.warm.older.FV().NumPy()],
                            state(whole) + [whole.warm.older.FV().NumPy()]):
        assert np.array_equal(mine, theirs)


@needs_petsc
@pytest.mark.parametrize("name", SCHEMES)
def test_march_starts_where_step_does(paper_meshes, monkeypatch, name):
    """`march`'s overlapped path forms each start from its own solutions (and the scheme's xⁿ before its second thread
    accepts step 1): FGMRES takes the iterations of `Scheme.step` in a loop, step by step (their right-hand sides
    differ by round-off only), over 10 steps started at step 2 (a march after steps already taken)."""
    counts = []
    for overlapped in (False, True):
        monkeypatch.setattr(marching, "MARCH_THREAD_MIN_DOFS", 0 if overlapped else 10**12)
        scheme = paper(name, paper_meshes[1], tolerance=1e-8)
        scheme.march(2)
        scheme.march(10)
        counts.append(scheme.solver.iterations)
    assert counts[0] == counts[1]
