"""The iterative solver's minimal-residual start (`fsivsp.timestepping.warmstart`) in every time scheme, in `march`'s
overlapped path and across a checkpoint: the direct solver's states, fewer iterations than from xⁿ or the
extrapolation, a residual no larger than the extrapolation's, a resumed run bit for bit the uninterrupted one."""
import ngsolve as ngs
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
    its second thread; the start differed from xⁿ (the least-squares combination ran), and was not formed for the
    direct solver."""
    monkeypatch.setattr(marching, "MARCH_THREAD_MIN_DOFS", 0 if overlapped else 10**12)
    direct, iterative = paper(name, paper_meshes[1], "direct"), paper(name, paper_meshes[1])
    starts = []
    original = warmstart.MinimalResidualStart.start

    def start(self, *args, **kwargs):
        out = original(self, *args, **kwargs)
        starts.append(out[0] is self.guess)
        return out
    monkeypatch.setattr(warmstart.MinimalResidualStart, "start", start)
    direct.march(8)
    iterative.march(8)
    assert any(starts) and iterative.warm.enabled and not direct.warm.enabled   # a factorisation takes no start
    for mine, theirs in zip(state(iterative), state(direct)):
        assert np.abs(mine - theirs).max() <= 1e-6 * np.abs(theirs).max()


@needs_petsc
@pytest.mark.parametrize("name", ["backward_euler", "bdf2"])
def test_fewer_iterations_than_from_the_last_solutions(paper_meshes, monkeypatch, name):
    """The paper's level 2, 20 steps, tolerance 1e-8: FGMRES takes fewer iterations in all from the minimal-residual
    combination of the last 6 solutions than of the last 2 (whose span holds 2xⁿ − xⁿ⁻¹); exact counts (measured:
    backward Euler 60 against 75, BDF2 242 against 253 with its start's solves). Step 1 (x⁰ alone) is the same in
    both. Crank–Nicolson starts from 2xⁿ − xⁿ⁻¹ itself (`MinimalResidualStart`'s ``combines``)."""
    counts = {}
    for history in (2, warmstart.HISTORY):
        monkeypatch.setattr(warmstart, "HISTORY", history)
        scheme = paper(name, paper_meshes[2], tolerance=1e-8)
        scheme.march(20)
        counts[history] = scheme.solver.iterations
    two, many = counts.values()
    assert two[0] == many[0]
    assert sum(many) < sum(two), counts


@needs_petsc
def test_start_no_worse_than_the_extrapolation(paper_meshes, monkeypatch):
    """Every start's residual is at most the reference start's (2xⁿ − xⁿ⁻¹ from step 3 on, xⁿ before), which the
    auto tolerance reduces; from step 6 on (the history full), the paper's level 2 smooth in time, at least 5×
    smaller."""
    ratios = []
    original = warmstart.MinimalResidualStart.start

    def start(self, time_scheme, n, rhs):
        out, reference = original(self, time_scheme, n, rhs)
        residual = rhs.CreateVector()
        residual.data = self._project * rhs - self._operator * out
        ratios.append(ngs.Norm(residual) / reference)
        return out, reference
    monkeypatch.setattr(warmstart.MinimalResidualStart, "start", start)
    scheme = paper("backward_euler", paper_meshes[2], tolerance="auto")
    scheme.march(12)
    assert max(ratios) <= 1 + 1e-10 and max(ratios[5:]) < 0.2, str(ratios)


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
    assert resumed.warm.count[0] == whole.warm.count[0] == warmstart.HISTORY
    for mine, theirs in zip(state(resumed) + [v.FV().NumPy() for v in resumed.warm.solutions + resumed.warm.products],
                            state(whole) + [v.FV().NumPy() for v in whole.warm.solutions + whole.warm.products]):
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
