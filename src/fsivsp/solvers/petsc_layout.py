"""Where the free dofs of the step system live in PETSc (`petsc`): one global order for serial and distributed runs.

PETSc's order is the velocity node by node (block size d; component by component where the components are not
free on the same dofs), then the pressure, each split evenly over the ranks: rank k owns one contiguous range of
rows, its share of the velocity nodes followed by its share of the pressure dofs. NGSolve's distributed mesh
leaves rank 0 without cells; the even split gives it rows all the same (PETSc moves their entries there), so that
every rank works in the solve. A dof that several ranks share is numbered by its master (NGSolve's
``MasterDofs``) and its number reaches the other ranks by a ``Cumulate``. Serially the numbers are 0, 1, ….
"""
from __future__ import annotations

import dataclasses

import ngsolve as ngs
import numpy as np

from ..fem.spaces import Spaces
from ..runtime import parallel
from .sparse import free_mask


@dataclasses.dataclass(frozen=True)
class Layout:
    """This rank's free dofs and their place in PETSc's global order (the module's docstring)."""

    local: np.ndarray       #: the free dofs of X_h's local vector in PETSc's order, velocity first
    nvel_local: int         #: how many of ``local`` are velocity dofs
    numbers: np.ndarray     #: their global numbers in PETSc's order
    master: np.ndarray      #: where this rank is the master of the dof (it inserts a cumulated value)
    field: np.ndarray       #: the velocity master dofs' numbers within the velocity field (its sub-matrix)
    blocksize: int          #: of the velocity field: d (node by node) or 1
    rows: tuple[int, int]   #: this rank's rows [start, stop), velocity rows first
    nvel_rows: int          #: how many of them are velocity rows
    size: int               #: all free dofs
    nvel: int               #: all velocity free dofs

    @property
    def velocity_rows(self) -> tuple[int, int]:
        return self.rows[0], self.rows[0] + self.nvel_rows

    @property
    def velocity_masters(self) -> np.ndarray:
        """The local velocity dofs this rank is the master of, in the order of ``field``."""
        return self.local[:self.nvel_local][self.master[:self.nvel_local]]


def free_order(spaces: Spaces, free: np.ndarray, matrix) -> tuple[np.ndarray, int, int]:
    """The free dofs of X_h's (local) vector in PETSc's order, how many are velocity dofs, and the velocity's
    block size: node by node (d) where every component is free on the same scalar dofs, else 1. Within each
    field the dofs follow the reverse Cuthill–McKee order of ``matrix``'s graph (scipy CSR of the local step
    matrix): a contiguous range of them is a compact patch of the mesh, so the ranks' shares of the rows meet
    on few couplings (AMG smoothers are Jacobi across ranks; NGSolve's own order puts the vertex dofs of a
    part before its higher dofs, and an even split of that cut every coupling: 27 → 48 iterations on 2 ranks)."""
    V, d = spaces.velocity, spaces.mesh.dim
    scalar = V.ndof // d
    components = free[:V.ndof].reshape(d, scalar)
    pressure = _banded(matrix, np.flatnonzero(free[V.ndof:]) + V.ndof, coupling=True)
    if (components == components[0]).all():
        nodes = _banded(matrix, np.flatnonzero(components[0]))
        velocity = (np.arange(d)[None, :] * scalar + nodes[:, None]).ravel()
        return np.concatenate([velocity, pressure]), len(velocity), d
    velocity = _banded(matrix, np.flatnonzero(free[:V.ndof]))
    return np.concatenate([velocity, pressure]), len(velocity), 1


def _banded(matrix, dofs: np.ndarray, coupling: bool = False) -> np.ndarray:
    """``dofs`` in the reverse Cuthill–McKee order of their block of ``matrix`` (``coupling``: of the pressure
    graph C Cᵀ, the pressure block itself being zero)."""
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    if not len(dofs):
        return dofs
    block = matrix[dofs]
    graph = block @ block.T if coupling else block[:, dofs]
    return dofs[reverse_cuthill_mckee(graph.tocsr(), symmetric_mode=True)]


def _chunks(total: int, parts: int, unit: int = 1) -> np.ndarray:
    """Boundaries of ``total`` items split evenly into ``parts`` ranges of whole ``unit``s."""
    return unit * (np.arange(parts + 1) * (total // unit) // parts)


def layout(spaces: Spaces, matrix) -> Layout:
    """The `Layout` of the step system's free dofs on this rank (collective under MPI); ``matrix``: the
    rank's (local) step matrix as scipy CSR."""
    X = spaces.mixed
    free = free_mask(X.FreeDofs(), X.ndof)
    local, nvel_local, blocksize = free_order(spaces, free, matrix)
    distributed = parallel.distributed()
    if distributed:
        master = np.fromiter(X.ParallelDofs().MasterDofs(), dtype=bool, count=X.ndof)[local]
        blocksize = min(parallel.gather(blocksize))
    else:
        master = np.ones(len(local), dtype=bool)
    counts = np.array(parallel.gather((int(master[:nvel_local].sum()), int(master[nvel_local:].sum()))))
    ranks, me = len(counts), parallel.rank()
    nvel, npre = counts.sum(axis=0)
    velocity_cuts, pressure_cuts = _chunks(nvel, ranks, blocksize), _chunks(npre, ranks)
    starts = velocity_cuts + pressure_cuts

    field = counts[:me, 0].sum() + np.arange(counts[me, 0])
    pressure = counts[:me, 1].sum() + np.arange(counts[me, 1])
    owner = np.searchsorted(velocity_cuts, field, side="right") - 1
    numbers_v = starts[owner] + field - velocity_cuts[owner]
    owner = np.searchsorted(pressure_cuts, pressure, side="right") - 1
    numbers_p = starts[owner] + np.diff(velocity_cuts)[owner] + pressure - pressure_cuts[owner]

    numbers = np.full(len(local), -1, dtype=np.int64)
    numbers[np.flatnonzero(master[:nvel_local])] = numbers_v
    numbers[nvel_local + np.flatnonzero(master[nvel_local:])] = numbers_p
    if distributed:
        numbers = from_masters(X, local, numbers, master)
    return Layout(local=local, nvel_local=nvel_local, numbers=numbers, master=master, field=field,
                  blocksize=blocksize, rows=(int(starts[me]), int(starts[me + 1])),
                  nvel_rows=int(velocity_cuts[me + 1] - velocity_cuts[me]), size=int(nvel + npre), nvel=int(nvel))


def from_masters(X: ngs.FESpace, local: np.ndarray, numbers: np.ndarray, master: np.ndarray) -> np.ndarray:
    """The masters' numbers on every rank that shares the dof: a distributed vector holding number + 1 at the
    master only, cumulated (exact: the numbers are integers far below 2⁵³)."""
    vector = ngs.GridFunction(X).vec.CreateVector()
    values = vector.FV().NumPy()
    values[:] = 0.0
    values[local[master]] = numbers[master] + 1
    vector.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
    vector.Cumulate()
    return np.rint(vector.FV().NumPy()[local]).astype(np.int64) - 1


def aij(PETSc, csr, comm):
    """The scipy CSR matrix ``csr`` as a PETSc AIJ matrix on ``comm``."""
    return PETSc.Mat().createAIJ(size=csr.shape, csr=(csr.indptr.astype(PETSc.IntType),
                                                      csr.indices.astype(PETSc.IntType), csr.data), comm=comm)


def from_summands(PETSc, csr, numbers: np.ndarray, rows: int, size: int):
    """The global MPIAIJ matrix (``size`` rows, ``rows`` of them on this rank) of which every rank holds the summand
    ``csr`` on its dofs, numbered ``numbers`` globally: the local part of a MATIS, converted."""
    mapping = PETSc.LGMap().create(numbers.astype(PETSc.IntType), comm=PETSc.COMM_WORLD)
    assembled = PETSc.Mat().createIS(((rows, size), (rows, size)), lgmapr=mapping, lgmapc=mapping,
                                     comm=PETSc.COMM_WORLD)
    part = aij(PETSc, csr, PETSc.COMM_SELF)
    assembled.setISLocalMat(part)
    assembled.assemble()
    assembled.convert("aij")  # in place
    part.destroy()
    mapping.destroy()
    return assembled
