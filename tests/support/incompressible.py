"""Nearly incompressible solids for the PETSc robustness tests: a case at λ/μ = 10⁴ with a solid pressure, and the
mean iterations per step of its scheme, without error norms."""
import dataclasses

from fsivsp.experiments.study import solver_statistics
from fsivsp.geometry import refined


def incompressible(case, steps: int = 3):
    """``case`` at λ/μ = 10⁴ with a solid pressure, ``steps`` steps, PETSc at 1e-12."""
    m = case.materials
    case = dataclasses.replace(case, materials=dataclasses.replace(m, lam=1e4 * m.mu), T=steps * case.dt)
    return case.with_discretisation(solid_pressure="continuous").with_solver(method="petsc", tolerance=1e-12)


def counts(case, levels, velocity: str | None = None) -> list[float]:
    """The mean iterations per step of ``case`` on ``levels`` (``velocity``: the velocity preconditioner every level
    must have used), without error norms."""
    found = []
    for level in levels:
        statistics = solver_statistics(case, refined(case.coarse_mesh(), level, case.discretisation.project_refinement),
                                       case.steps)
        assert velocity is None or statistics["preconditioner"]["velocity"] == velocity, statistics
        found.append(statistics["iterations"]["mean"])
    return found
