"""The iterative solver of step 1 of (5.1): MinRes with a block-diagonal preconditioner.

The step matrix is [[A, −ΔtBᵀ], [−ΔtB, 0]] with A = ρM + 2νΔt K_F + Δt²(2μ K_S + λ D_S). MinRes
converges in a number of iterations bounded independently of h if the preconditioner is the Riesz map of
a norm in which the step is well posed (Mardal–Winther): diag(A⁻¹, S⁻¹) with S = Δt² B A⁻¹ Bᵀ.

- A⁻¹ ≈ a symmetric multigrid V-cycle of the coupled P1 velocity block over the refinement hierarchy
  (`multigrid.Multigrid`) on the vertex dofs, or without a hierarchy Σ_j E_j AMG(A_jj) E_jᵀ (NGSolve's
  ``h1amg`` of each component's diagonal block, `forms.velocity_component_block`); plus Jacobi on the
  higher-order velocity dofs (MINI's bubbles, Taylor–Hood's edge, face and cell dofs).
- S⁻¹ ≈ ρ_F/Δt² L_p⁻¹ + 2ν/Δt M_p⁻¹ (Cahouet–Chabard), L_p the pressure Laplacian by ``h1amg``
  (`forms.pressure_laplacian`) and M_p⁻¹ by the diagonal of the pressure mass. L_p vanishes on the
  fluid's boundaries where the velocity is free (the interface and traction boundaries): there the
  weak gradient −∫_F p div w of the step penalises the pressure trace, and a Neumann L_p needs a third
  more iterations on the paper's experiment (58 against 44 on level 3 with A⁻¹ exact).

Everything is an NGSolve ``BaseMatrix`` built once per run; a step costs matrix-vector products only.
"""
from __future__ import annotations

import time
from math import sqrt

import numpy as np
import ngsolve as ngs
from ngsolve.krylovspace import MinResSolver

from .. import forms
from ..materials import Materials
from ..spaces import Spaces
from .direct import SolverError
from .multigrid import COARSE_MAX_DOFS, Multigrid, vertex_levels

#: Default tolerance: MinRes stops when its (preconditioned) residual is below this fraction of the
#: right-hand side's. On the paper's experiment (Δt = 1e-2, levels 0–3) 1e-12 leaves the error norms
#: equal to the direct solver's to 4.4e-8 relative, 1e-10 only to 5.2e-6 and 1e-8 to 5.9e-4.
TOLERANCE = 1e-12
MAX_ITERATIONS = 2000


class NotConverged(SolverError):
    """MinRes reached its iteration limit above its tolerance."""


def _bits(mask: np.ndarray) -> ngs.BitArray:
    return ngs.BitArray(mask.tolist())


def _amg(mesh: ngs.Mesh, integrand, dirichlet: str, definedon: str | None = None):
    """NGSolve's ``h1amg`` for ∫ integrand(u, w) on continuous P1 (the vertex dofs of any H1 space),
    and what must stay alive with it."""
    p1 = ngs.H1(mesh, order=1, dirichlet=dirichlet, definedon=definedon) if definedon else \
        ngs.H1(mesh, order=1, dirichlet=dirichlet)
    form = ngs.BilinearForm(p1)
    form += integrand(*p1.TnT())
    amg = ngs.Preconditioner(form, "h1amg")
    form.Assemble()
    return amg.mat, (p1, form, amg)


class BlockPreconditioner:
    """diag(A⁻¹, S⁻¹) of the step matrix on X_h = V_h × Q_h (see the module's docstring); ``mat`` is the
    preconditioner as one NGSolve ``BaseMatrix`` (zero on the non-free dofs)."""

    def __init__(self, matrix: ngs.BaseMatrix, spaces: Spaces, mat: Materials, dt: float):
        mesh, X, V, Q = spaces.mesh, spaces.mixed, spaces.velocity, spaces.pressure
        d, nv = mesh.dim, mesh.nv
        component = V.ndof // d
        if component * d != V.ndof:
            raise SolverError("iterative: the velocity space is not d copies of one scalar space")
        free = np.fromiter(X.FreeDofs(), dtype=bool, count=X.ndof)
        self._keep = []
        higher = np.zeros(X.ndof, dtype=bool)
        for j in range(d):
            higher[j * component + nv:(j + 1) * component] = free[j * component + nv:(j + 1) * component]
        levels = vertex_levels(mesh)
        self.multigrid = len(levels[1]) > 1 and d * levels[1][0] <= COARSE_MAX_DOFS
        parts = [self._velocity_multigrid(spaces, mat, dt, free, levels) if self.multigrid
                 else self._velocity_amg(spaces, mat, dt, free)]
        if higher.any():
            parts.append(matrix.CreateSmoother(_bits(higher)))
        self.velocity = parts[0]
        for part in parts[1:]:
            self.velocity = self.velocity + part

        boundaries = set(mesh.GetBoundaries()) - set(spaces.dirichlet.split("|"))
        laplacian, keep = _amg(mesh, forms.pressure_laplacian, "|".join(sorted(boundaries)), forms.FLUID)
        self._keep.append(keep)
        p, q = Q.TnT()
        mass = ngs.BilinearForm(Q)
        mass += forms.pressure_mass(p, q)
        mass.Assemble()
        schur = mat.rho_fluid / dt**2 * self._vertices(laplacian, Q, nv) \
            + 2 * mat.nu / dt * mass.mat.CreateSmoother(Q.FreeDofs())
        if Q.ndof > nv:  # Taylor–Hood k ≥ 2: the pressure's higher-order dofs by the diagonal of L_p
            full = ngs.BilinearForm(Q)
            full += forms.pressure_laplacian(p, q)
            full.Assemble()
            qfree = np.fromiter(Q.FreeDofs(), dtype=bool, count=Q.ndof)
            qfree[:nv] = False
            schur = schur + mat.rho_fluid / dt**2 * full.mat.CreateSmoother(_bits(qfree))
            self._keep.append(full)
        pressure = ngs.la.Embedding(X.ndof, ngs.IntRange(V.ndof, X.ndof))
        self._keep += [mass, parts]
        #: S⁻¹ and A⁻¹ on X_h, and their sum, the preconditioner
        self.schur = pressure @ schur @ pressure.T
        self.mat = self.velocity + self.schur

    def _velocity_multigrid(self, spaces: Spaces, mat: Materials, dt: float, free: np.ndarray,
                            levels: tuple[np.ndarray, list[int]]) -> ngs.BaseMatrix:
        """The coupled P1 velocity block by `Multigrid` over the refinement hierarchy ``levels``
        (`multigrid.vertex_levels`), on X_h's vertex dofs."""
        mesh, X = spaces.mesh, spaces.mixed
        d, nv, component = mesh.dim, mesh.nv, spaces.velocity.ndof // mesh.dim
        p1 = ngs.VectorH1(mesh, order=1, dirichlet=spaces.dirichlet)
        form = ngs.BilinearForm(p1)
        form += forms.velocity_block(*p1.TnT(), spaces, mat, dt)
        form.Assemble()
        self._check_vertices(np.fromiter(p1.FreeDofs(), dtype=bool, count=p1.ndof), free, d, nv, component)
        cycle = Multigrid(form.mat, p1.FreeDofs(), *levels)
        self._keep += [p1, form, cycle]
        gather = sum((ngs.la.Embedding(p1.ndof, ngs.IntRange(j * nv, (j + 1) * nv))
                      @ ngs.la.Embedding(X.ndof, ngs.IntRange(j * component, j * component + nv)).T for j in range(1, d)),
                     ngs.la.Embedding(p1.ndof, ngs.IntRange(0, nv)) @ ngs.la.Embedding(X.ndof, ngs.IntRange(0, nv)).T)
        self._keep.append(gather)
        return gather.T @ cycle @ gather

    def _velocity_amg(self, spaces: Spaces, mat: Materials, dt: float, free: np.ndarray) -> ngs.BaseMatrix:
        """Without a refinement hierarchy: for each component, ``h1amg`` of its diagonal block
        (`forms.velocity_component_block`) on its P1 dofs."""
        mesh, X = spaces.mesh, spaces.mixed
        d, nv, component = mesh.dim, mesh.nv, spaces.velocity.ndof // mesh.dim
        blocks = None
        for j in range(d):
            amg, keep = _amg(mesh, lambda u, w, j=j: forms.velocity_component_block(u, w, j, mat, dt, mesh),
                             spaces.dirichlet)
            self._check_vertices(np.tile(np.fromiter(keep[0].FreeDofs(), dtype=bool, count=nv), d), free, d, nv,
                                 component)
            embed = ngs.la.Embedding(X.ndof, ngs.IntRange(j * component, j * component + nv))
            block = embed @ amg @ embed.T
            blocks = block if blocks is None else blocks + block
            self._keep.append(keep)
        return blocks

    @staticmethod
    def _check_vertices(p1_free: np.ndarray, free: np.ndarray, d: int, nv: int, component: int) -> None:
        """The P1 space's free dofs (component-major) are X_h's free vertex dofs of the velocity."""
        ours = np.concatenate([free[j * component:j * component + nv] for j in range(d)])
        if not np.array_equal(p1_free, ours):
            raise SolverError("iterative: the P1 dofs of the velocity do not follow the vertices")

    @staticmethod
    def _vertices(p1_operator: ngs.BaseMatrix, space: ngs.FESpace, nv: int) -> ngs.BaseMatrix:
        """A P1 operator on the vertex dofs of ``space`` (the first ``nv`` of an H1 space)."""
        if space.ndof == nv:
            return p1_operator
        embed = ngs.la.Embedding(space.ndof, ngs.IntRange(0, nv))
        return embed @ p1_operator @ embed.T


class IterativeSolver:
    """MinRes with `BlockPreconditioner` on the step matrix, warm-started from the previous step.

    ``solve_step(rhs, boundary, out, guess)`` sets ``out = boundary + A_ff⁻¹ rhs``, iterating from the free part
    of ``guess`` until the preconditioned residual is below ``tol`` times the right-hand side's; raises
    `NotConverged` after ``maxiter`` iterations. ``iterations`` lists the count of every solve.
    """

    method = "iterative"
    #: The scheme may run a solve concurrently with other work of its own (`Scheme.march`).
    overlap = True
    #: Builds the preconditioner (an object with ``mat``) from (matrix, spaces, materials, dt).
    preconditioner_type = BlockPreconditioner

    def __init__(self, matrix: ngs.BaseMatrix, spaces: Spaces, materials: Materials, dt: float,
                 tol: float = TOLERANCE, maxiter: int = MAX_ITERATIONS):
        if not 0 < tol < 1:
            raise ValueError(f"tolerance: expected a number in (0, 1), got {tol!r}")
        start = time.perf_counter()
        self.matrix, self.tol, self.maxiter = matrix, tol, maxiter
        self.preconditioner = self.preconditioner_type(matrix, spaces, materials, dt)
        self._free = ngs.Projector(spaces.mixed.FreeDofs(), True)
        self._minres = MinResSolver(matrix, self.preconditioner.mat, tol=None, atol=1.0, maxiter=maxiter)
        self._increment = matrix.CreateColVector()
        self._work = matrix.CreateColVector()
        self.iterations: list[int] = []
        self.residual = float("nan")
        self.factor_seconds = time.perf_counter() - start  # the preconditioner's set-up

    def solve_step(self, rhs: ngs.BaseVector, boundary: ngs.BaseVector, out: ngs.BaseVector,
              guess: ngs.BaseVector | None = None) -> None:
        """out = boundary + A_ff⁻¹ rhs (``guess`` may be ``out`` itself)."""
        increment = self._increment
        if guess is None:
            increment[:] = 0.0
        else:
            increment.data = self._free * guess
        self._work.data = self.preconditioner.mat * rhs
        scale = sqrt(max(ngs.InnerProduct(self._work, rhs), 0.0))
        self._minres.atol = self.tol * scale if scale > 0 else 1e-300
        self._minres.Solve(rhs, increment, initialize=False)
        self.iterations.append(self._minres.iterations)
        self.residual = self._minres.residuals[-1] / scale if scale > 0 else 0.0
        if self._minres.residuals[-1] > self._minres.atol:
            raise NotConverged(f"iterative: MinRes did not reach the tolerance {self.tol:g} in {self.maxiter} "
                               f"iterations (relative residual {self.residual:.2e})")
        out.data = boundary + increment

    def progress(self) -> str:
        """The solver and its last iteration count, for a progress line."""
        return f"MinRes {self.iterations[-1] if self.iterations else 0} its"

    def statistics(self) -> dict:
        """What a run records of its solver: iterations per step (mean, max), set-up time."""
        counts = self.iterations or [0]
        return {"method": self.method, "tolerance": self.tol, "residual": self.residual,
                "setup_seconds": self.factor_seconds,
                "iterations": {"mean": float(np.mean(counts)), "max": int(max(counts)), "solves": len(self.iterations)}}
