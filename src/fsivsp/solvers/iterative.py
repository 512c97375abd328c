"""The iterative solver of step 1 of (5.1): MinRes with a block-diagonal preconditioner.

The step matrix is [[A, −ΔtBᵀ], [−ΔtB, 0]] with A = ρM + 2νΔt K_F + Δt²(2μ K_S + λ D_S). MinRes
converges in a number of iterations bounded independently of h if the preconditioner is the Riesz map of
a norm in which the step is well posed (Mardal–Winther): diag(A⁻¹, S⁻¹) with S = Δt² B A⁻¹ Bᵀ.

- A⁻¹ ≈ `multigrid.TwoLevel`: symmetric Gauss–Seidel on the whole velocity space (MINI's bubbles, Taylor–Hood's
  edge, face and cell dofs included) around a correction of its vertex block, the coupled P1 velocity block, by a
  V-cycle over the refinement hierarchy (`multigrid.Multigrid`); without a hierarchy by Σ_j E_j AMG(A_jj) E_jᵀ,
  NGSolve's ``h1amg`` of each component's diagonal block (`forms.velocity_component_block`).
- S⁻¹ ≈ the least-squares commutator F⁻¹ (Yᵀ A Y − C) F⁻¹, or Cahouet–Chabard on a large mesh without a
  hierarchy (`schur`).

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
from .sparse import SolverError
from .multigrid import SMOOTHING, Multigrid, TwoLevel, algebraic_multigrid, bits, has_hierarchy, vertex_block, \
    vertex_gather, vertex_levels
from .schur import LeastSquaresCommutator, pressure_schur

#: Default tolerance: MinRes stops when its (preconditioned) residual is below this fraction of the
#: right-hand side's. On the paper's experiment (Δt = 1e-2, levels 0–3) 1e-12 leaves the error norms
#: equal to the direct solver's to 6.0e-8 relative, 1e-10 only to 3.6e-6 and 1e-8 to 2.1e-4 (with 28, 20 and 13
#: iterations per step on level 3).
TOLERANCE = 1e-12
MAX_ITERATIONS = 2000


class NotConverged(SolverError):
    """MinRes reached its iteration limit above its tolerance."""


def velocity_vertex_dofs(spaces: Spaces) -> np.ndarray:
    """X_h's dof of each (velocity component, vertex): V_h is d copies of one scalar H1 space whose first nv dofs
    are the vertices' (NGSolve's hierarchical basis), checked at the first, middle and last vertex."""
    mesh, V = spaces.mesh, spaces.velocity
    d, nv = mesh.dim, mesh.nv
    component = V.ndof // d
    if component * d != V.ndof:
        raise SolverError("iterative: the velocity space is not d copies of one scalar space")
    vertices = np.arange(d)[:, None] * component + np.arange(nv)[None, :]
    for v in {0, nv // 2, nv - 1}:
        if not set(vertices[:, v]) <= set(spaces.mixed.GetDofNrs(ngs.NodeId(ngs.VERTEX, v))):
            raise SolverError("iterative: the velocity's dofs do not start with the vertices")
    return vertices


def velocity_smoothing(spaces: Spaces) -> int:
    """Gauss–Seidel sweeps on the whole velocity space before and after the vertex block's V-cycle: one for MINI
    (whose bubbles are cell-local: on level 3 of the 3D fluid ball 43 MinRes iterations against 42 with two, at
    two thirds of the cost), 2k for Taylor–Hood k (P2 on level 2 of the 3D solid ball: 77 iterations against 102
    with one; P3 on level 1: 69 with four, 91 with two, 28 with the velocity block exact)."""
    return 1 if spaces.family == "mini" else SMOOTHING * spaces.order


class BlockPreconditioner:
    """diag(A⁻¹, S⁻¹) of the step matrix on X_h = V_h × Q_h (see the module's docstring); ``mat`` is the
    preconditioner as one NGSolve ``BaseMatrix`` (zero on the non-free dofs), ``velocity`` and ``schur`` its
    blocks, ``multigrid`` whether the velocity's vertex block takes the V-cycle (else ``h1amg``)."""

    def __init__(self, matrix: ngs.BaseMatrix, spaces: Spaces, mat: Materials, dt: float):
        mesh, X = spaces.mesh, spaces.mixed
        velocity = np.fromiter(X.FreeDofs(), dtype=bool, count=X.ndof)
        velocity[spaces.velocity.ndof:] = False
        vertices = velocity_vertex_dofs(spaces)
        gather = vertex_gather(vertices, velocity)
        vertex_free = velocity[vertices.ravel()]
        self.multigrid = has_hierarchy(mesh, mesh.dim)
        coarse = Multigrid(vertex_block(matrix, gather), bits(vertex_free), *vertex_levels(mesh)) if self.multigrid \
            else self._component_amg(spaces, mat, dt, vertex_free)
        self.velocity = TwoLevel(matrix, bits(velocity), gather, coarse, steps=velocity_smoothing(spaces))
        self.pressure = pressure_schur(matrix, spaces, mat, dt, vertices)
        self.schur = self.pressure.mat
        self.mat = self.velocity + self.schur

    def describe(self) -> dict:
        """Which approximations the two blocks take (for the run's record)."""
        schur = self.pressure
        if isinstance(schur, LeastSquaresCommutator):
            pressure = "least-squares commutator" + (", corrected" if schur.corrected else "") \
                + ("" if schur.inverse == "multigrid" else ", F factorised")
        else:
            pressure = "Cahouet-Chabard"
        return {"velocity": "Gauss-Seidel and multigrid" if self.multigrid else "Gauss-Seidel and h1amg",
                "pressure": pressure}

    def _component_amg(self, spaces: Spaces, mat: Materials, dt: float, vertex_free: np.ndarray) -> ngs.BaseMatrix:
        """Without a refinement hierarchy: for each component, ``h1amg`` of its diagonal block
        (`forms.velocity_component_block`) on the vertex block's unknowns of that component."""
        mesh = spaces.mesh
        d, nv = mesh.dim, mesh.nv
        self._amg = []
        blocks = None
        for j in range(d):
            amg, keep = algebraic_multigrid(
                mesh, lambda u, w, j=j: forms.velocity_component_block(u, w, j, mat, dt, mesh), spaces.dirichlet)
            if not np.array_equal(np.fromiter(keep[0].FreeDofs(), dtype=bool, count=nv), vertex_free[j * nv:(j + 1) * nv]):
                raise SolverError("iterative: the P1 dofs of the velocity do not follow the vertices")
            embed = ngs.la.Embedding(d * nv, ngs.IntRange(j * nv, (j + 1) * nv))
            block = embed @ amg @ embed.T
            blocks = block if blocks is None else blocks + block
            self._amg.append(keep)
        return blocks


class IterativeSolver:
    """MinRes with `BlockPreconditioner` on the step matrix, warm-started from the previous step.

    ``solve_step(rhs, boundary, out, guess)`` sets ``out = boundary + A_ff⁻¹ rhs``, iterating from the free part
    of ``guess`` until the preconditioned residual is below ``tol`` times the right-hand side's; raises
    `NotConverged` after ``maxiter`` iterations. ``iterations`` lists the count of every solve.
    """

    method = "iterative"
    #: The scheme may run a solve concurrently with other work of its own (`Scheme.march`).
    overlap = True
    #: Its products and cycles run under NGSolve's TaskManager (`marching.march`).
    threaded = True
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
        self._work.data = self.preconditioner.mat * rhs
        scale = sqrt(max(ngs.InnerProduct(self._work, rhs), 0.0))
        if scale == 0:  # a zero right-hand side: the increment is zero (MinRes would divide by its norm)
            self.iterations.append(0)
            self.residual = 0.0
            out.data = boundary
            return
        if guess is None:
            increment[:] = 0.0
        else:
            increment.data = self._free * guess
        self._minres.atol = self.tol * scale
        self._minres.Solve(rhs, increment, initialize=False)
        self.iterations.append(self._minres.iterations)
        self.residual = self._minres.residuals[-1] / scale
        if self._minres.residuals[-1] > self._minres.atol:
            raise NotConverged(f"iterative: MinRes did not reach the tolerance {self.tol:g} in {self.maxiter} "
                               f"iterations (relative residual {self.residual:.2e})")
        out.data = boundary + increment

    def progress(self) -> str:
        """The solver and its last iteration count, for a progress line."""
        return f"MinRes {self.iterations[-1] if self.iterations else 0} its"

    def statistics(self) -> dict:
        """What a run records of its solver: iterations per step (mean, max), set-up time, the preconditioner."""
        counts = self.iterations or [0]
        return {"method": self.method, "tolerance": self.tol, "residual": self.residual,
                "setup_seconds": self.factor_seconds, "preconditioner": self.preconditioner.describe(),
                "iterations": {"mean": float(np.mean(counts)), "max": int(max(counts)), "solves": len(self.iterations)}}
