"""Solves with the Gram matrix G of an error norm: the G-orthogonal projections of the exact fields (`norms`).

Small spaces factorise G (Cholesky). Above `DIRECT_MAX` used dofs the factorisation's fill grows faster than
the dofs (on level 4 of the 3D fluid ball it doubled the run's peak memory), and the projections are solved by
PETSc's conjugate gradients with BoomerAMG instead. Both go through `solvers.symmetric` (`symmetric_solver`). A
singular G (the stress norm ‖Cε(u)‖ on the solid, whose kernel is the rigid motions) is consistent for every load
∫ Cε(E):Cε(w).
"""
from __future__ import annotations

import ngsolve as ngs
import numpy as np

from ..solvers import petsc_available
from ..solvers.sparse import bits
from ..solvers.symmetric import Factorised, Kernel, PETScCG, symmetric_solver

#: Used dofs above which G is not factorised (PETSc's CG instead, where petsc4py imports). On level 4 of the 3D
#: fluid ball (MINI, 190 000 dofs in one velocity component's norm) the Cholesky factorisation took 84 s and 2.2 GB.
DIRECT_MAX = 50_000


def gram_solver(gram: ngs.BaseMatrix, space: ngs.FESpace, used: np.ndarray,
                kernel: Kernel | None) -> Factorised | PETScCG:
    """load, out ↦ out = G⁺ load on the ``used`` dofs (a mask) of ``space`` (`symmetric_solver`). ``kernel``: an
    orthonormal basis (columns) of G's kernel on the dofs it names, or None. CG where G has more than `DIRECT_MAX`
    used dofs and PETSc is available, else the factorisation."""
    iterate = used.sum() > DIRECT_MAX and petsc_available() is None
    return symmetric_solver(gram, bits(used), kernel, iterate)
