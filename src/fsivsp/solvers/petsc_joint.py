"""The pressure block of `petsc.PETScSolver`'s fieldsplit when the solid keeps a pressure (`fem.spaces`, docs/solvers.md
"The solid pressure"): one block over (p, ŝ), the fluid's pressure and the solid's, whose Schur complement is
S = −(C A⁻¹ Cᵀ + D), D = −A_pp = ∫_S ŝ r/λ (the step's solid rows, `fem.forms`).

The joint Cahouet–Chabard approximation adds the two limits of C A⁻¹ Cᵀ + D, each inverted:

    S⁻¹ ≈ −[(C Q̃⁻¹ Cᵀ + D)⁻¹ + M̃⁻¹],   Q̃ = diag(ρM) on the vertex dofs of V_h, diag(A) on its higher dofs,
    M̃ = ∫_F Δt/(2ν) p q + ∫_S (1/(2μ) + 1/λ) ŝ r:

the first the mass-dominated limit (A ≈ ρM; the bubbles, edge and face dofs are stiffness-dominated already, so
their mass would overweight them), by BoomerAMG (``schur_laplacian_``); the second the viscous limit in the fluid and
the stiffness limit in the solid (C A⁻¹ Cᵀ + D ≈ (Δt/2ν) M_p, (1/2μ + 1/λ) M_ŝ), by three Chebyshev–Jacobi
steps (``schur_mass_``). In the prototype of issue 33 its condition number against S stayed at 3–7 for λ/μ up to 10⁴,
Δt from 10⁻³ to 0.1, MINI and Taylor–Hood k = 1, 2, 2D and 3D. A fluid-only least-squares commutator plus a solid block
missed the coupling across Γ (condition ≥ 29 at Δt = 0.1), and the joint least-squares commutator's bound grew like
h⁻¹ where the solid is stiffness-dominated.

The joint least-squares commutator (``schur_approximation = "joint-lsc"``, the default in 3D, `petsc`):

    S⁻¹ ≈ −L⁻¹ (Yᵀ A Y + D) L⁻¹,   L = C Y + D,   Y = diag(A)⁻¹ Cᵀ,

its middle factor corrected on the higher dofs as the fluid's (`petsc_schur`); ``"joint-lsc-mass"`` adds M̃⁻¹. In 3D
Cahouet–Chabard's lower spectral bound falls with h in the fluid (docs/solvers.md, "The solid pressure"), the
commutator's does not; in 2D the commutator grows where the solid is stiffness-dominated (Δt = 0.1).
"""
from __future__ import annotations

import ngsolve as ngs
import numpy as np

from ..fem import forms
from ..fem.spaces import Spaces
from ..geometry import SOLID
from ..model.materials import Materials
from .petsc_schur import (
    SchurPreconditioner,
    commutator,
    higher_rows,
    install,
    laplacian_basis,
    part,
    pressure_laplacian,
    velocity_mass,
)
from .sparse import to_scipy_csr


def joint_pressure_block(solver, spaces: Spaces, materials: Materials, dt: float) -> SchurPreconditioner:
    """The joint Cahouet–Chabard pressure block (the module's docstring) as PETSc's Python PC of ``solver``'s
    fieldsplit, built from the blocks of its step matrix; ``dt`` the step's τ."""
    PETSc, (velocity, pressure) = solver.PETSc, solver.fields
    a = solver.A.createSubMatrix(velocity, velocity)
    c = solver.A.createSubMatrix(pressure, velocity)
    d = solver.A.createSubMatrix(pressure, pressure)
    name = solver.options["schur_approximation"]
    if name.startswith("joint-lsc"):
        mass = _mass_inverse(solver, spaces, materials, dt) if name == "joint-lsc-mass" else None
        return _joint_lsc(solver, spaces, a, c, d, mass)
    mass = velocity_mass(solver, spaces, materials)
    weights = part(mass, velocity)
    values = weights.getArray()
    values[:] = np.where(higher_rows(solver, spaces), a.getDiagonal().getArray(), values)
    laplacian, y = pressure_laplacian(PETSc, c, weights)
    laplacian.axpy(-1.0, d, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
    inverse = _mass_inverse(solver, spaces, materials, dt)
    solver.keep += [a, c, d, weights, y, laplacian]
    return install(solver, SchurPreconditioner(PETSc, laplacian, None, None,
                                                 solver.ksp.getOptionsPrefix() + "schur_laplacian_", mass=inverse,
                                                 basis=laplacian_basis(solver, spaces)))


def _mass_inverse(solver, spaces: Spaces, materials: Materials, dt: float):
    """M̃⁻¹ of the module's docstring: a KSP under ``schur_mass_`` on the weighted mass."""
    weighted = _weighted_mass(solver, spaces, materials, dt)
    inverse = solver.PETSc.KSP().create(comm=solver.comm)
    inverse.setOptionsPrefix(solver.ksp.getOptionsPrefix() + "schur_mass_")
    inverse.setOperators(weighted)
    inverse.setFromOptions()
    inverse.setUp()
    solver.keep += [weighted, inverse]
    return inverse


def _joint_lsc(solver, spaces: Spaces, a, c, d, mass=None) -> SchurPreconditioner:
    """The joint least-squares commutator over (p, ŝ): S⁻¹ ≈ −L⁻¹ (Yᵀ A Y + D) L⁻¹, L = C Y + D, Y = diag(A)⁻¹ Cᵀ,
    its middle factor corrected on the higher dofs as `petsc_schur`'s (``schur_approximation = "joint-lsc"``)."""
    PETSc, structure = solver.PETSc, solver.PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN
    laplacian, middle, y = commutator(solver, spaces, a, c)
    laplacian.axpy(-1.0, d, structure=structure)
    middle.axpy(-1.0, d, structure=structure)
    solver.keep += [a, c, d, y, laplacian, middle]
    return install(solver, SchurPreconditioner(PETSc, laplacian, middle, None,
                                                 solver.ksp.getOptionsPrefix() + "schur_laplacian_", mass=mass,
                                                 basis=laplacian_basis(solver, spaces)))


def _weighted_mass(solver, spaces: Spaces, materials: Materials, dt: float):
    """M̃ of the module's docstring on the pressure field (PETSc's order), assembled on X_h."""
    (_, p), (_, q) = forms.trial_test(spaces)
    s, r = forms.solid_trial_test(spaces)
    form = ngs.BilinearForm(spaces.mixed)
    form += forms.pressure_mass(p, q, spaces, dt / (2 * materials.nu))
    form += forms.integral((1 / (2 * materials.mu) + 1 / forms.bulk_modulus(materials, spaces.mesh.dim)) * s * r,
                           spaces, SOLID)
    form.Assemble()
    local = to_scipy_csr(form.mat.local_mat if solver.distributed else form.mat)
    L = solver.layout
    whole = solver.petsc_matrix(local[L.local][:, L.local].tocsr())
    block = whole.createSubMatrix(solver.fields[1], solver.fields[1])
    whole.destroy()
    return block
