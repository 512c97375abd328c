"""Nearly incompressible solids for the PETSc robustness tests: a case at λ/μ = 10⁴ with a solid pressure, and the
mean iterations per step of its study."""
import dataclasses

from fsivsp.experiments.study import study


def incompressible(case, steps: int = 3):
    """``case`` at λ/μ = 10⁴ with a solid pressure, ``steps`` steps, PETSc at 1e-12."""
    m = case.materials
    case = dataclasses.replace(case, materials=dataclasses.replace(m, lam=1e4 * m.mu), T=steps * case.dt)
    return case.with_discretisation(solid_pressure="continuous").with_solver(method="petsc", tolerance=1e-12)


def counts(case, levels, velocity: str | None = None) -> list[float]:
    """The mean iterations per step of ``case`` on ``levels`` (``velocity``: the velocity preconditioner every level
    must have used)."""
    records = study(case, levels)
    assert velocity is None or all(r["preconditioner"]["velocity"] == velocity for r in records)
    return [r["iterations"]["mean"] for r in records]
