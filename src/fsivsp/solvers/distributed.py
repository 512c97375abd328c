"""The solver of step 1 of (5.1) on a distributed mesh (``mpirun``): MinRes with a block preconditioner that
NGSolve applies over MPI ranks.

The step matrix is [[A, −ΔtBᵀ], [−ΔtB, 0]] (`iterative`); the preconditioner is again diag(A⁻¹, S⁻¹) with
Cahouet–Chabard's S⁻¹ ≈ ρ_F/Δt² L_p⁻¹ + 2ν/Δt M_p⁻¹, but its pieces are ones NGSolve distributes:

- A⁻¹ and ρ_F/Δt² L_p⁻¹ together: NGSolve's BDDC of the block-diagonal form A ⊕ Δt²/ρ_F L_p on V_h × Q_h
  (one form, so one preconditioner; the pressure there vanishes on the fluid's boundaries where the velocity is
  free, as in `iterative`);
- 2ν/Δt M_p⁻¹: BDDC of the pressure mass on every free pressure dof (of M_v ⊕ M_p, restricted to the pressure:
  NGSolve's Jacobi, the "local" preconditioner, failed to assemble on 3 ranks, "sparse matrix row full").

BDDC treats all of the velocity's dofs (MINI's bubbles, Taylor–Hood's higher orders) and needs no refinement
hierarchy. Everything is built once per run; a step costs matrix-vector products and their communication.
"""
from __future__ import annotations

import ngsolve as ngs

from .. import forms
from ..geometry import FLUID
from ..materials import Materials
from ..spaces import Spaces
from .iterative import MAX_ITERATIONS, TOLERANCE, IterativeSolver

#: The solver names that mean the distributed solver on a distributed mesh (no direct method runs there).
DISTRIBUTED_SOLVERS = ("auto", "iterative")


class DistributedPreconditioner:
    """diag(A⁻¹, S⁻¹) of the step matrix by BDDC and Jacobi (see the module's docstring); ``mat`` is the
    preconditioner as one NGSolve ``BaseMatrix`` on X_h (zero on the non-free dofs)."""

    def __init__(self, matrix: ngs.BaseMatrix, spaces: Spaces, mat: Materials, dt: float):
        mesh, X = spaces.mesh, spaces.mixed
        free = sorted(set(mesh.GetBoundaries()) - set(spaces.dirichlet.split("|")))
        # Q_h with the Laplacian's Dirichlet boundaries: the same dofs in the same order as X_h's pressure
        pressure = ngs.H1(mesh, order=spaces.order, definedon=FLUID, dirichlet="|".join(free))
        product = spaces.velocity * pressure
        (v, p), (w, q) = product.TnT()
        blocks = ngs.BilinearForm(product)
        blocks += forms.velocity_block(v, w, spaces, mat, dt)
        blocks += dt**2 / mat.rho_fluid * forms.pressure_laplacian(p, q)
        bddc = ngs.Preconditioner(blocks, "bddc")
        blocks.Assemble()

        (v, p), (w, q) = X.TnT()
        mass = ngs.BilinearForm(X)
        mass += forms.pressure_mass(p, q) + v * w * ngs.dx  # the velocity's part is projected away below
        mass_inverse = ngs.Preconditioner(mass, "bddc")
        mass.Assemble()
        pressure_dofs = ngs.BitArray(X.FreeDofs())
        pressure_dofs[:spaces.velocity.ndof] = False
        pressure = ngs.Projector(pressure_dofs, True)
        self._keep = (product, blocks, bddc, mass, mass_inverse)
        self.mat = bddc.mat + 2 * mat.nu / dt * pressure @ mass_inverse.mat @ pressure


class DistributedSolver(IterativeSolver):
    """`IterativeSolver` (MinRes, warm starts, the same record) with `DistributedPreconditioner`."""

    method = "distributed"
    overlap = False  # its products and inner products communicate: one MPI call at a time
    preconditioner_type = DistributedPreconditioner


def unsupported(solver: str | None, initial_velocity: str) -> str | None:
    """Why a distributed run cannot take these options (one line naming the option), or None."""
    if solver not in (None, *DISTRIBUTED_SOLVERS):
        return f"solver: {solver!r} does not run under mpirun; expected one of {', '.join(DISTRIBUTED_SOLVERS)}"
    if initial_velocity == "projection":
        return "initial_velocity: the projection needs a direct solver, which does not run under mpirun; use interpolation"
    return None


def distributed_solver(matrix: ngs.BaseMatrix, spaces: Spaces, materials: Materials, dt: float, name: str,
                       tol: float = TOLERANCE, maxiter: int = MAX_ITERATIONS) -> DistributedSolver:
    """The solver of a distributed step matrix; ``name`` must be one of `DISTRIBUTED_SOLVERS`."""
    if name not in DISTRIBUTED_SOLVERS:
        raise ValueError(f"solver: {name!r} does not run distributed (mpirun); expected one of "
                         f"{', '.join(DISTRIBUTED_SOLVERS)}")
    return DistributedSolver(matrix, spaces, materials, dt, tol, maxiter)
