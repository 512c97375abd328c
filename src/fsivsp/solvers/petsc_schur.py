"""The pressure block of `petsc.PETScSolver`'s fieldsplit: the Schur complement S = −C A⁻¹ Cᵀ of step 1's
matrix [[A, Cᵀ], [C, 0]] (C = −ΔtB), as PETSc's Python PC built with PETSc's sparse products from the blocks:

- the least-squares commutator (Elman et al.), S⁻¹ ≈ F⁻¹ (Yᵀ A Y − E) F⁻¹ with Y = diag(A)⁻¹ Cᵀ and F = C Y (a
  pressure Laplacian, F⁻¹ by BoomerAMG cycles); "corrected" for MINI's bubbles (and Taylor–Hood k = 1's edge
  dofs), whose part Y_hᵀ A_hh Y_h of the middle factor is replaced by F_h diag(F_h)⁻¹ F_h, F_h = C Y_h (E their
  difference): without it the bubbles' stiffness, scaled by Δt² λ, dominates the middle factor; for Taylor–Hood
  k ≥ 2 in 2D, where that replacement underestimates, diag(A) weighted ×6 on the higher dofs instead (`commutator`;
  ×4 with F's AMG in the hierarchical basis, `petsc_basis`);
- Cahouet–Chabard, S⁻¹ ≈ F_ρ⁻¹ + diag(M_p/(2ν))⁻¹/Δt, F_ρ = C diag(ρM)⁻¹ Cᵀ: the mass's and the viscosity's
  limits of S added (ν region-wise where fluids differ).
"""
from __future__ import annotations

import ngsolve as ngs
import numpy as np

from ..fem import forms
from ..fem.spaces import Spaces
from ..model.materials import Materials
from ..runtime import parallel
from .petsc_basis import lagrange_basis, takes_lagrange
from .sparse import to_scipy_csr


class SchurPreconditioner:
    """PETSc's Python PC for the pressure block, −S⁻¹ ≈ −(L⁻¹ R L⁻¹ + w ∘ + M⁻¹) (see the module's docstring): ``L`` a
    pressure Laplacian applied by an inner PC under the prefix ``prefix`` (BoomerAMG, its cycles set by
    ``schur_laplacian_pc_hypre_boomeramg_max_iter``), ``R`` a sparse matrix (None: one application of L⁻¹ and no
    second), ``weight`` a diagonal (None: none), ``mass`` a KSP applying M⁻¹ (None: none; `petsc_joint`). With a
    ``basis`` P (`petsc_basis`) L⁻¹ is P (Pᵀ L P)⁻¹ Pᵀ, the inner PC on Pᵀ L P."""

    def __init__(self, PETSc, laplacian, middle, weight, prefix: str, mass=None, basis=None):
        self.basis = basis
        self.amg = PETSc.PC().create(comm=laplacian.getComm())
        self.amg.setOptionsPrefix(prefix)
        self.amg.setOperators(laplacian if basis is None else galerkin(PETSc, laplacian, basis))
        self.amg.setFromOptions()
        self.amg.setUp()
        self.middle, self.weight, self.mass = middle, weight, mass
        self._u, self._v = laplacian.createVecs()
        if basis is not None:
            self._in, self._out = basis.createVecs()

    def laplacian_solve(self, x, y) -> None:
        """y = L⁻¹ x by the inner PC (in the ``basis`` if any)."""
        if self.basis is None:
            self.amg.apply(x, y)
        else:
            self.basis.multTranspose(x, self._in)
            self.amg.apply(self._in, self._out)
            self.basis.mult(self._out, y)

    def free(self) -> None:
        """Free the inner PC and the basis (not `destroy`: petsc4py calls a context's destroy with the PC)."""
        self.amg.destroy()
        if self.basis is not None:
            for obj in (self.basis, self._in, self._out):
                obj.destroy()

    def apply(self, pc, x, y) -> None:
        if self.middle is None:
            self.laplacian_solve(x, y)
        else:
            self.laplacian_solve(x, self._u)
            self.middle.mult(self._u, self._v)
            self.laplacian_solve(self._v, y)
        if self.weight is not None:
            self._u.pointwiseMult(self.weight, x)
            y.axpy(1.0, self._u)
        if self.mass is not None:
            self.mass.solve(x, self._u)
            y.axpy(1.0, self._u)
        y.scale(-1.0)


def part(vector, field):
    """A copy of ``vector``'s entries on the index set ``field``."""
    borrowed = vector.getSubVector(field)
    copy = borrowed.copy()
    vector.restoreSubVector(field, borrowed)
    return copy


def pressure_block(solver, spaces: Spaces, materials: Materials, dt: float) -> SchurPreconditioner:
    """The pressure block as PETSc's Python PC: the least-squares commutator (``schur_approximation =
    lsc``, the default) or Cahouet–Chabard (``cahouet-chabard``), see the module's docstring; built with
    PETSc's sparse products from the blocks A (velocity) and C (pressure–velocity) of the step matrix."""
    PETSc, (velocity, pressure) = solver.PETSc, solver.fields
    a = solver.A.createSubMatrix(velocity, velocity)
    c = solver.A.createSubMatrix(pressure, velocity)
    if solver.options["schur_approximation"] == "lsc":
        laplacian, middle, y = commutator(solver, spaces, a, c)
        weight = None
    else:
        mass, pmass = velocity_mass(solver, spaces, materials), pressure_mass(solver, spaces, materials)
        laplacian, y = pressure_laplacian(PETSc, c, part(mass, velocity))
        weight, middle = part(pmass, pressure), None
        weight.reciprocal()
        weight.scale(1 / dt)
    solver.keep += [m for m in (a, c, y, laplacian, middle, weight) if m is not None]
    return install(solver, SchurPreconditioner(PETSc, laplacian, middle, weight,
                                               solver.ksp.getOptionsPrefix() + "schur_laplacian_",
                                               basis=laplacian_basis(solver, spaces)))


def laplacian_basis(solver, spaces: Spaces):
    """The pressure Laplacian's basis for its inner PC: `petsc_basis.lagrange_basis` where `petsc_basis.takes_lagrange`,
    else None (the hierarchical basis of Q_h)."""
    return lagrange_basis(solver, spaces) if takes_lagrange(spaces, solver.options) else None


def install(solver, context: SchurPreconditioner) -> SchurPreconditioner:
    """``context`` as the preconditioner of the fieldsplit's Schur complement."""
    pc = solver.ksp.getPC().getFieldSplitSubKSP()[1].getPC()
    pc.setType("python")
    pc.setPythonContext(context)
    return context


def commutator(solver, spaces: Spaces, a, c):
    """(C Y, Yᵀ A Y, Y), Y = D⁻¹ Cᵀ: the least-squares commutator's Laplacian and middle factor, the middle factor
    corrected on the higher dofs for MINI and Taylor–Hood k = 1 (`correct_higher`). D = diag(A), times ``w =
    schur_higher_weight`` on the higher dofs (`petsc.LAGRANGE_2D`, `petsc.DEFAULTS_HIGHER_2D`): their share of Yᵀ A Y,
    which overweights a smooth pressure, falls like w⁻², their share of F like w⁻¹."""
    weights = a.getDiagonal()
    weight = float(solver.options["schur_higher_weight"])
    if weight != 1:
        weights.pointwiseMult(weights, solver.field_vector(np.where(higher_rows(solver, spaces), weight, 1.0)))
    laplacian, y = pressure_laplacian(solver.PETSc, c, weights)
    middle = galerkin(solver.PETSc, a, y)
    if spaces.family == "mini" or spaces.order == 1:
        correct_higher(solver, middle, a, c, y, spaces)
    return laplacian, middle, y


def pressure_laplacian(PETSc, c, diagonal):
    """(C Y, Y) with Y = diag(``diagonal``)⁻¹ Cᵀ: the pressure Laplacian of the discrete divergence."""
    y = c.transpose(PETSc.Mat())
    inverse = diagonal.copy()
    inverse.reciprocal()
    y.diagonalScale(L=inverse)
    return c.matMult(y), y


def galerkin(PETSc, a, y):
    """Yᵀ A Y as Yᵀ (A Y), Yᵀ made explicitly: each rank forms its rows' entries alone, in one order, so that runs
    on the same ranks round alike. PETSc's ``ptap`` sums the ranks' contributions to a row in the order they arrive
    (3 ranks: 1 run in 3 differed from the others at round-off, so a resumed run was not the uninterrupted one)."""
    return y.transpose(PETSc.Mat()).matMult(a.matMult(y))


def higher_rows(solver, spaces: Spaces) -> np.ndarray:
    """Which of this rank's velocity rows are higher-order dofs (bubbles, edges, faces: not a vertex's)."""
    scalar = spaces.velocity.ndof // spaces.mesh.dim
    return solver.layout.velocity_masters % scalar >= spaces.mesh.nv


def correct_higher(solver, middle, a, c, y, spaces: Spaces) -> None:
    """The corrected commutator (the module's docstring): the higher dofs' term Y_hᵀ A Y_h of the
    middle factor replaced by F_h diag(F_h)⁻¹ F_h, F_h = C Y_h (in place)."""
    structure = solver.PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN
    higher = higher_rows(solver, spaces)
    if not parallel.total(np.array([higher.sum()]))[0]:
        return
    y_h = y.copy()
    y_h.diagonalScale(L=solver.field_vector(higher.astype(float)))
    f_h = c.matMult(y_h)
    scale = f_h.getDiagonal()
    values = scale.getArray()
    values[:] = np.where(values > 0, 1.0 / np.where(values > 0, values, 1.0), 0.0)
    scaled = f_h.copy()
    scaled.diagonalScale(L=scale)
    middle.axpy(-1.0, galerkin(solver.PETSc, a, y_h), structure=structure)
    middle.axpy(1.0, f_h.matMult(scaled), structure=structure)


def diagonal(solver, form: ngs.BilinearForm):
    """The diagonal of ``form`` (on X_h, assembled here) as a PETSc vector in PETSc's order."""
    form.Assemble()
    matrix = form.mat.local_mat if solver.distributed else form.mat
    vector = solver.A.createVecRight()
    solver.load_values(to_scipy_csr(matrix).diagonal(), vector, solver.distributed)
    return vector


def velocity_mass(solver, spaces: Spaces, materials: Materials):
    """The diagonal of the velocity mass ρM (PETSc's order)."""
    return diagonal(solver, forms.velocity_mass(spaces, materials))


def pressure_mass(solver, spaces: Spaces, materials: Materials):
    """The diagonal of the pressure mass M_p/(2ν) (PETSc's order)."""
    (_, p), (_, q) = forms.trial_test(spaces)
    form = ngs.BilinearForm(spaces.mixed)
    form += forms.pressure_mass(p, q, spaces, 1 / (2 * materials.nu))
    return diagonal(solver, form)
