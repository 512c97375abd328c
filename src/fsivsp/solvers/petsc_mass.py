"""Whether the step's velocity block is dominated by its mass (`stiffness_ratio`): then symmetric SOR sweeps
precondition it, not a BoomerAMG cycle (`petsc.PETScSolver`).

The velocity block is A = ρM + K with K = 2νΔt K_F + Δt²(2μ K_S + λ D_S) (`forms.step_matrix`). Since K ≥ 0,
λ_min(D⁻¹A) ≥ min_i (ρM)_ii/A_ii · λ_min(D_M⁻¹ ρM) (D, D_M the diagonals of A and ρM), and λ_max(D⁻¹A) is bounded
by the element's couplings: the condition of the Jacobi-scaled block is at most a constant of the element times

    q = max_i A_ii / (ρM)_ii,

the largest ratio of a velocity dof's whole diagonal to its mass's (1 + 2νΔt/h² and 1 + Δt²(2μ + λ)/(ρh²) up to the
element's constants). Where q is of order one (a short step for the mesh) the block is a scaled mass matrix whose
spectrum does not depend on h, and SSOR sweeps reduce its error as much as an AMG cycle, whose hierarchy costs
several times more an application. q is algebraic: it holds for every time scheme, element and boundary term.

SSOR replaces BoomerAMG on the whole block only. MINI's condensed bubbles in 3D (`petsc_pmg.Condensed`) are kept at
every q: they eliminate the bubbles exactly and cycle on P1's vertex block, and beat SSOR where the mass dominates
too (the 3D tube of examples/pressure_wave.toml at 249 599 unknowns, q = 4.1, 10 steps, the auto tolerance, with
4 cycles on the commutator's F against SSOR's 2: 4.7 iterations and 0.44 s a step against 6.8 and 0.68 s; at Δt/5,
q ≈ 1.6: 4.3 and 0.36 s against 6.0 and 0.52 s). Where the mass dominates their commutator takes 2 cycles on F, not
4 (the tube: the same 4.7 iterations at 0.81× the time a step).
"""
from __future__ import annotations

from collections.abc import Mapping

from ..fem.spaces import Spaces
from ..model.materials import Materials
from .petsc_pmg import COARSE
from .petsc_schur import part, velocity_mass


def stiffness_ratio(solver, spaces: Spaces, materials: Materials) -> float:
    """q = max_i A_ii / (ρM)_ii over the velocity rows of ``solver``'s step matrix (the module's docstring), over
    every rank."""
    mass, velocity = velocity_mass(solver, spaces, materials), solver.fields[0]
    diagonal, mass_diagonal = part(solver.A.getDiagonal(), velocity), part(mass, velocity)
    diagonal.pointwiseDivide(diagonal, mass_diagonal)
    ratio = diagonal.max()[1]
    for vector in (mass, diagonal, mass_diagonal):
        vector.destroy()
    return ratio


#: The velocity block where its mass dominates (the module's docstring): two Richardson steps with symmetric SOR
#: (SSOR within each rank) instead of BoomerAMG, taken by default where the stiffness ratio q ≤ `MASS_DOMINATED`.
#: The 3D tube (examples/pressure_wave.toml, maxh 0.08, 4 steps, tolerance 1e-12), Δt from 1.25e-5 to 1.25e-4:
#: iterations a step with BoomerAMG / SSOR at q = 2.7: 21.0 / 21.0; 27.7: 22.3 / 21.8; 61: 26.3 / 27.3; 108:
#: 28.3 / 35.0; 168: 29.3 / 41.3. At maxh 0.06 (282 415 unknowns, q = 4.1) a velocity solve takes 31 ms against 90.
DEFAULTS_SSOR: dict[str, str] = {
    "velocity_preconditioner": "ssor",
    "fieldsplit_velocity_ksp_type": "richardson",
    "fieldsplit_velocity_ksp_max_it": "2",
    "fieldsplit_velocity_ksp_norm_type": "none",
    "fieldsplit_velocity_pc_type": "sor",
}

#: The largest stiffness ratio q (the module's docstring) at which the velocity block takes `DEFAULTS_SSOR` in place of
#: BoomerAMG by default, and MINI's condensed block 2 cycles on the commutator's F (`petsc.STIFF_F_CYCLES` beyond).
MASS_DOMINATED = 30.0


def ratio_for(solver, spaces: Spaces, materials: Materials, velocity: str) -> float | None:
    """The stiffness ratio q where the velocity block's preconditioner ``velocity`` reads it, else None (not
    computed): BoomerAMG on the whole block, which `DEFAULTS_SSOR` replaces at q ≤ `MASS_DOMINATED` (unless the
    user's options set the block, `sets_velocity`), and MINI's condensed bubbles, whose commutator takes fewer cycles
    on F there (`petsc.velocity_options`)."""
    return stiffness_ratio(solver, spaces, materials) if velocity in ("boomeramg", "condensed") else None


def sets_velocity(given: Mapping[str, object]) -> bool:
    """Whether the user's options ``given`` (keys without the prefix) set the velocity block's preconditioner."""
    return "velocity_preconditioner" in given or any(key.startswith(("fieldsplit_velocity_", COARSE)) for key in given)
