"""The coupled modes' eigenproblem: (10) with every field ∝ e^{st}, as the first-order pencil A x = s E x.

The unknowns are x = (v, u, p) on the free dofs, u = v/s the displacement: σ_S = Cε(u) exactly by (18), as the
scheme keeps it (`timestepping.scheme`). With M = ∫_Ω ρ v·w, K_F = 2ν ∫_F ε(v):ε(w), K_S = ∫_S Cε(v):ε(w) and
Bᵀp = ∫_F p div w (`fem.forms`):

    [ −K_F   −K_S R̃ᵀ   Bᵀ ] [v]       [ M  0  0 ] [v]
    [  R̃      0        0  ] [u]  = s  [ 0  I  0 ] [u]
    [  B      0        0  ] [p]       [ 0  0  0 ] [p]

Row 1 is the momentum equation s M v + K_F v + K_S u − Bᵀp = 0, row 2 s u = v on the solid, row 3 div v = 0. u
has the free velocity dofs of solid cells (V_h|_S), R̃ restricts a velocity to them. E is singular in p: infinite
eigenvalues, which shift-and-invert maps to 0. Keeping σ ∈ S_h instead of u (the [v; σ] pencil) gives the same
eigenvalues s ≠ 0 plus a static one for every stress outside Cε(V_h|_S); u is the smaller pencil (issue 35's
prototype: 66 against 98 unknowns).

Static modes, s = 0: rigid motions of a solid free of walls (v = 0, p = 0) and a constant pressure in every fluid
part closed by walls and Γ, balanced by the static displacement it causes (K_S u = Bᵀp, v = 0). So A − σE is
singular at σ = 0 whenever a fluid is closed.

PETSc matrices, serial or over the MPI ranks of a distributed mesh: every rank's local matrices are summands
(`solvers.petsc_layout.from_summands`), the identity blocks entered by the dof's master only. Each rank's rows are
its masters' v, then u, then p.
"""
from __future__ import annotations

from dataclasses import dataclass

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from ..fem import forms
from ..fem.spaces import Spaces
from ..geometry import SOLID
from ..model.materials import Materials
from ..runtime import parallel
from ..solvers import free_mask, to_scipy_csr
from ..solvers.petsc_layout import aij, from_masters, from_summands


@dataclass
class Numbering:
    """Where x = (v, u, p) lives: this rank's free velocity dofs ``velocity``, which of them are ``solid`` (u's),
    its free pressure dofs ``pressure`` (of X_h's local vector), the global numbers of its local x = (v, u, p) on
    them (``numbers``), whether this rank is their master, its rows [start, stop) and the global size."""

    velocity: np.ndarray
    solid: np.ndarray
    pressure: np.ndarray
    numbers: np.ndarray
    master: np.ndarray
    rows: tuple[int, int]
    size: int


def local_matrix(form: ngs.BilinearForm) -> sp.csr_matrix:
    """This rank's (local) matrix of ``form`` as scipy CSR."""
    matrix = form.Assemble().mat
    return to_scipy_csr(matrix.local_mat if isinstance(matrix, ngs.la.ParallelMatrix) else matrix)


def numbering(spaces: Spaces) -> Numbering:
    """The global numbers of x = (v, u, p) (collective under MPI): rank by rank its masters' v, u, p; a dof shared
    by ranks takes its master's numbers (a cumulated vector, as `solvers.petsc_layout`)."""
    X, nv = spaces.mixed, spaces.velocity.ndof
    free = free_mask(X.FreeDofs(), X.ndof)
    velocity, pressure = np.flatnonzero(free[:nv]), nv + np.flatnonzero(free[nv:])
    solid = solid_dofs(spaces)[velocity]
    dofs = np.concatenate([velocity, velocity[solid], pressure])
    shared = X.ParallelDofs()
    master = (np.ones(len(dofs), dtype=bool) if shared is None
              else np.fromiter(shared.MasterDofs(), dtype=bool, count=X.ndof)[dofs])
    size = int(parallel.total(np.array([master.sum()]))[0])
    start = int(sum(parallel.gather(int(master.sum()))[:parallel.rank()]))
    numbers = np.full(len(dofs), -1, dtype=np.int64)
    numbers[master] = start + np.arange(int(master.sum()))   # v, u, p masters in this order
    if shared is not None:   # v, u and p each by a vector of their own
        blocks = np.cumsum([0, len(velocity), int(solid.sum()), len(pressure)])
        numbers = np.concatenate([from_masters(X, dofs[a:b], numbers[a:b], master[a:b])
                                  for a, b in zip(blocks[:-1], blocks[1:])])
    return Numbering(velocity, solid, pressure, numbers, master, (start, start + int(master.sum())), size)


def solid_dofs(spaces: Spaces) -> np.ndarray:
    """Which of X_h's (local) dofs are velocity dofs of a solid cell (of any rank's, under MPI)."""
    X = spaces.mixed
    vector = ngs.GridFunction(X).vec.CreateVector()
    values = vector.FV().NumPy()
    values[:] = 0.0
    for element in spaces.mesh.Elements(ngs.VOL):
        if element.mat == SOLID:
            values[[dof for dof in spaces.velocity.GetDofNrs(element) if dof >= 0]] = 1.0
    if X.ParallelDofs() is not None:
        vector.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
        vector.Cumulate()
    return vector.FV().NumPy().real > 0


class Pencil:
    """A and E of the module's docstring as PETSc matrices (``PETSc``: the module of `solvers.petsc_init.petsc`,
    complex or real), with their `Numbering`."""

    def __init__(self, PETSc, spaces: Spaces, materials: Materials):
        self.PETSc, self.spaces = PETSc, spaces
        self.numbering = n = numbering(spaces)
        iv, ip, iu = n.velocity, n.pressure, n.velocity[n.solid]
        mass, viscous, stiffness, divergence = (
            local_matrix(form) for form in (forms.velocity_mass(spaces, materials),
                                            forms.fluid_viscous(spaces, materials),
                                            forms.solid_stiffness(spaces, materials), forms.divergence(spaces)))
        masters = n.master[len(iv):len(iv) + len(iu)].astype(float)   # the identities are entered by the master
        restriction = sp.csr_matrix((masters, (np.arange(len(iu)), np.flatnonzero(n.solid))), shape=(len(iu), len(iv)))
        divergence = divergence[iv][:, ip]
        self.A = self._matrix(sp.bmat([[-viscous[iv][:, iv], -stiffness[iv][:, iu], divergence],
                                       [restriction, None, None], [divergence.T, None, None]], format="csr"))
        self.E = self._matrix(sp.block_diag([mass[iv][:, iv], sp.diags(masters), sp.csr_matrix((len(ip), len(ip)))],
                                            format="csr"))

    def _matrix(self, summand: sp.csr_matrix):
        """The global matrix of which ``summand`` is this rank's part (serially: itself)."""
        PETSc, n = self.PETSc, self.numbering
        summand = summand.astype(PETSc.ScalarType)
        summand.sort_indices()
        if parallel.world() is None:
            return aij(PETSc, summand, PETSc.COMM_SELF)
        return from_summands(PETSc, summand, n.numbers, n.rows[1] - n.rows[0], n.size)

    def destroy(self) -> None:
        for matrix in (self.A, self.E):
            matrix.destroy()
