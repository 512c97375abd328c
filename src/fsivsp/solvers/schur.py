"""The pressure block of the iterative solver's preconditioner: approximations of S⁻¹, S = Δt² B A⁻¹ Bᵀ the
Schur complement of the step matrix [[A, −ΔtBᵀ], [−ΔtB, 0]] (`iterative`).

`LeastSquaresCommutator` (the default where the mesh has a refinement hierarchy) follows Elman, Howle,
Shadid, Shuttleworth and Tuminaro (SIAM J. Sci. Comput. 27, 2006): with D = diag(A), Y = D⁻¹(−ΔtBᵀ) and
F = Δt² B D⁻¹ Bᵀ (a pressure Laplacian built from the discrete B, so it sees the interface and the element),

    S⁻¹ ≈ F⁻¹ (Yᵀ A Y) F⁻¹.

The velocity's higher-order dofs (MINI's cell bubbles, Taylor–Hood's P2 edge functions) vanish on the boundary
of their patch: their part F_h of F and their part Y_hᵀ A_hh Y_h of the middle factor both act like h²|∇q|² on
a smooth pressure q. Where the viscosity dominates (νΔt ≫ ρh²) the rest of the middle factor acts like
h⁴|∇²q|², F like a Laplacian and S like the pressure mass, so the bubbles' term makes the approximation too
large by (hk)⁻² on a pressure of wave number k. fsivsp replaces that term by F_h diag(F_h)⁻¹ F_h, which is
F_h to within a constant on the highest modes and a bi-Laplacian on smooth ones (our derivation, measured):
κ(P⁻¹S) on levels 1–4 of the paper's experiment (Δt = 1e-2) 1.6, 1.8, 2.7, 4.3 with the replacement,
1.6, 3.2, 9.4, 34 without; on levels 1–3 of the 3D fluid ball 1.6, 1.8 (levels 1–2) against Cahouet–Chabard's
12.0, 17.6, 25.0. For a P_k pressure with k ≥ 2 the replacement underestimates (κ ≈ 20 on the 2D fluid disk,
levels 0–2, against 1.7, 1.8, 3.6 without), and the plain commutator is used. F⁻¹ is a multigrid V-cycle over
the refinement hierarchy (`multigrid`), factorised on a mesh without one if it is small.

`CahouetChabard`, S⁻¹ ≈ ρ_F/Δt² L_p⁻¹ + 2ν/Δt M_p⁻¹ with NGSolve's ``h1amg`` for the pressure Laplacian L_p and
the diagonal of the pressure mass M_p, is the fallback on a large mesh without a hierarchy. L_p vanishes on
the fluid's boundaries where the velocity is free (the interface and traction boundaries): there the weak
gradient −∫_F p div w penalises the pressure trace, as at a traction boundary (tests/test_mini_traction.py).
"""
from __future__ import annotations

import numpy as np
import ngsolve as ngs
import scipy.sparse as sp

from .. import forms
from ..materials import Materials
from ..spaces import Spaces
from .sparse import to_ngsolve, to_scipy_csr
from .symmetric import factorised
from .multigrid import Multigrid, TwoLevel, algebraic_multigrid, bits, has_hierarchy, vertex_block, vertex_gather, \
    vertex_levels

#: Gauss–Seidel sweeps of F's V-cycle and V-cycles per application: F appears twice in the approximation, and
#: its dofs (the fluid's pressure) are few, so that two V(4,4) cost 7% of a MinRes iteration on level 4 of the 3D
#: fluid ball. There MinRes needs 53 iterations with two, 64 with one (and with a W-cycle), 49 with F factorised;
#: on level 3 39, 43 and 39.
PRESSURE_SMOOTHING, PRESSURE_CYCLES = 4, 2

#: Block Gauss–Seidel sweeps over the vertex patches of a P_k pressure, k ≥ 2, above the V-cycle of its vertex
#: block: point Gauss–Seidel left 165 MinRes iterations on level 1 of the 3D solid ball (Taylor–Hood k = 2,
#: the velocity block exact) where F factorised needs 28, the patches 34.
PATCH_SMOOTHING = 2

#: Without a refinement hierarchy F is factorised up to this many fluid pressure dofs, else `CahouetChabard`.
FACTORISE_MAX_DOFS = 30_000


def fluid_divergence(spaces: Spaces, dt: float) -> sp.csr_matrix:
    """−ΔtB on X_h's free dofs: −Δt ∫_F q div v, rows the pressure dofs, columns the velocity dofs (the step
    matrix's off-diagonal block, `forms.step_matrix`)."""
    V, Q = spaces.velocity, spaces.pressure
    v, q = V.TrialFunction(), Q.TestFunction()
    form = ngs.BilinearForm(trialspace=V, testspace=Q)
    form += forms.integral(-dt * q * ngs.div(v), spaces, forms.FLUID)
    form.Assemble()
    free = np.fromiter(spaces.mixed.FreeDofs(), dtype=bool, count=spaces.mixed.ndof)
    rows, cols = free[V.ndof:], free[:V.ndof]
    return (sp.diags(rows.astype(float)) @ to_scipy_csr(form.mat, verify=False) @ sp.diags(cols.astype(float))).tocsr()


def inverse_diagonal(matrix: ngs.BaseMatrix, free: np.ndarray) -> np.ndarray:
    """1 / diag(matrix) on the ``free`` dofs, 0 elsewhere (NGSolve's Jacobi applied to ones)."""
    ones = matrix.CreateColVector()
    ones.FV().NumPy()[:] = 1.0
    out = matrix.CreateColVector()
    out.data = matrix.CreateSmoother(bits(free)) * ones
    return out.FV().NumPy().copy()


class LeastSquaresCommutator:
    """S⁻¹ ≈ F⁻¹ (Yᵀ A Y − C) F⁻¹ (see the module's docstring): ``mat`` on X_h's pressure dofs. ``matrix`` is the
    step matrix, ``velocity_vertices`` the (d, nv) array of X_h's vertex dofs of the velocity; ``corrected``:
    C = Y_hᵀ A_hh Y_h − F_h diag(F_h)⁻¹ F_h on the higher-order dofs h, else C = 0. ``inverse``: "multigrid"
    (the mesh must have a hierarchy) or "factorised"."""

    def __init__(self, matrix: ngs.BaseMatrix, spaces: Spaces, dt: float, velocity_vertices: np.ndarray,
                 corrected: bool, inverse: str):
        X, nV, nq = spaces.mixed, spaces.velocity.ndof, spaces.pressure.ndof
        self.inverse = inverse
        free = np.fromiter(X.FreeDofs(), dtype=bool, count=X.ndof)
        velocity = free.copy()
        velocity[nV:] = False
        inverse_d = inverse_diagonal(matrix, velocity)[:nV]
        minus_b = fluid_divergence(spaces, dt)                             # −ΔtB, nq × nV
        y = (sp.diags(inverse_d) @ minus_b.T).tocsr()                        # Y = D⁻¹(−ΔtBᵀ), nV × nq
        f = (minus_b @ y).tocsr()                                           # F = Δt² B D⁻¹ Bᵀ
        #: the fluid's pressure dofs (the rows of F that are not zero)
        self.used = np.diff(f.indptr) > 0
        higher = velocity[:nV].copy()
        higher[velocity_vertices.ravel()] = False
        self.corrected = corrected and bool(higher.any())
        #: X_h-sized Y, whose columns are the pressure dofs in Q_h's numbering
        self._y = to_ngsolve(sp.vstack([y, sp.csr_matrix((X.ndof - nV, nq))]).tocsr())
        middle = self._y.CreateTranspose() @ matrix @ self._y
        if self.corrected:
            y_h = self._y_rows(y, higher, X.ndof)
            bubbles = to_scipy_csr(y_h.CreateTranspose() @ (matrix @ y_h), verify=False)   # Y_hᵀ A_hh Y_h
            f_h = (minus_b @ sp.diags(np.where(higher, inverse_d, 0.0)) @ minus_b.T).tocsr()
            scale = f_h.diagonal()
            scale = np.where(scale > 0, 1.0 / np.where(scale > 0, scale, 1.0), 0.0)
            self._correction = to_ngsolve(bubbles - f_h @ sp.diags(scale) @ f_h)
            middle = middle - self._correction
        self.f = to_ngsolve(f + sp.diags((~self.used).astype(float)))
        self.f_inverse = self._inverse(spaces, inverse)
        pressure = ngs.la.Embedding(X.ndof, ngs.IntRange(nV, X.ndof))
        self.mat = pressure @ (self.f_inverse @ middle @ self.f_inverse) @ pressure.T

    @staticmethod
    def _y_rows(y: sp.csr_matrix, rows: np.ndarray, height: int) -> ngs.BaseMatrix:
        """The rows ``rows`` (a mask) of Y, X_h-sized."""
        kept = sp.diags(rows.astype(float)) @ y
        return to_ngsolve(sp.vstack([kept, sp.csr_matrix((height - y.shape[0], y.shape[1]))]).tocsr())

    def _inverse(self, spaces: Spaces, inverse: str) -> ngs.BaseMatrix:
        """F⁻¹ on Q_h: a V-cycle (P1 pressure) or `TwoLevel` over the V-cycle of its vertex block (P_k, k ≥ 2),
        or a factorisation."""
        used = bits(self.used)
        if inverse == "factorised":
            return factorised(self.f, used)
        mesh = spaces.mesh
        levels = vertex_levels(mesh)
        if spaces.pressure.ndof == mesh.nv:
            return Multigrid(self.f, used, *levels, smoothing=PRESSURE_SMOOTHING, iterations=PRESSURE_CYCLES)
        gather = vertex_gather(np.arange(mesh.nv)[None, :], self.used)   # Q_h's first nv dofs: the vertices
        cycle = Multigrid(vertex_block(self.f, gather), bits(self.used[:mesh.nv]), *levels,
                          smoothing=PRESSURE_SMOOTHING)
        return TwoLevel(self.f, used, gather, cycle, steps=PATCH_SMOOTHING, blocks=vertex_patches(spaces.pressure, self.used))


def vertex_patches(space: ngs.FESpace, used: np.ndarray) -> list[list[int]]:
    """For each vertex, the ``used`` dofs of ``space`` on it and on the edges, faces and cells around it (a
    vertex patch; every dof of a node of the mesh lies in one)."""
    mesh = space.mesh
    patches = []
    for vertex in mesh.vertices:
        nodes = [vertex, *vertex.edges, *vertex.faces]
        if mesh.dim == 3:
            nodes += [ngs.NodeId(ngs.CELL, element.nr) for element in vertex.elements]
        patch = sorted({dof for node in nodes for dof in space.GetDofNrs(node) if dof >= 0 and used[dof]})
        if patch:
            patches.append(patch)
    return patches


class CahouetChabard:
    """S⁻¹ ≈ ρ_F/Δt² L_p⁻¹ + 2ν/Δt M_p⁻¹ (see the module's docstring): ``mat`` on X_h's pressure dofs; the
    higher-order pressure dofs (k ≥ 2) take the diagonal of L_p."""

    def __init__(self, spaces: Spaces, mat: Materials, dt: float):
        mesh, X, V, Q = spaces.mesh, spaces.mixed, spaces.velocity, spaces.pressure
        nv = mesh.nv
        boundaries = set(mesh.GetBoundaries()) - set(spaces.dirichlet.split("|"))
        laplacian, self._amg = algebraic_multigrid(mesh, forms.pressure_laplacian, "|".join(sorted(boundaries)),
                                                   forms.FLUID)
        p, q = Q.TnT()
        mass = ngs.BilinearForm(Q)
        mass += forms.pressure_mass(p, q)
        mass.Assemble()
        vertices = laplacian if Q.ndof == nv else \
            ngs.la.Embedding(Q.ndof, ngs.IntRange(0, nv)) @ laplacian @ ngs.la.Embedding(Q.ndof, ngs.IntRange(0, nv)).T
        schur = mat.rho_fluid / dt**2 * vertices + 2 * mat.nu / dt * mass.mat.CreateSmoother(Q.FreeDofs())
        self._keep = [mass]
        if Q.ndof > nv:  # the pressure's higher-order dofs by the diagonal of L_p
            full = ngs.BilinearForm(Q)
            full += forms.pressure_laplacian(p, q)
            full.Assemble()
            higher = np.fromiter(Q.FreeDofs(), dtype=bool, count=Q.ndof)
            higher[:nv] = False
            schur = schur + mat.rho_fluid / dt**2 * full.mat.CreateSmoother(bits(higher))
            self._keep.append(full)
        pressure = ngs.la.Embedding(X.ndof, ngs.IntRange(V.ndof, X.ndof))
        self.mat = pressure @ schur @ pressure.T


def pressure_schur(matrix: ngs.BaseMatrix, spaces: Spaces, mat: Materials, dt: float,
                   velocity_vertices: np.ndarray) -> LeastSquaresCommutator | CahouetChabard:
    """The approximation of S⁻¹ for this mesh: the least-squares commutator with F⁻¹ by multigrid where the mesh
    has a refinement hierarchy, factorised where it has none and F is small, else Cahouet–Chabard."""
    corrected = spaces.family == "mini" or spaces.order == 1
    if has_hierarchy(spaces.mesh):
        return LeastSquaresCommutator(matrix, spaces, dt, velocity_vertices, corrected, "multigrid")
    fluid = np.fromiter(spaces.pressure.FreeDofs(), dtype=bool, count=spaces.pressure.ndof).sum()
    if fluid <= FACTORISE_MAX_DOFS:
        return LeastSquaresCommutator(matrix, spaces, dt, velocity_vertices, corrected, "factorised")
    return CahouetChabard(spaces, mat, dt)
