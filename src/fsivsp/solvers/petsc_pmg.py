"""The velocity block of `petsc.PETScSolver`'s fieldsplit over its vertex dofs: a two-level p-multigrid cycle for
Taylor–Hood, MINI's bubbles condensed.

BoomerAMG on the hierarchical P_{k+1} basis of Taylor–Hood's velocity coarsens poorly (the edge and face dofs are not
an M-matrix's unknowns: Taylor–Hood k = 2 in 3D took 47–54 iterations, 12–13 with the velocity block factorised;
Taylor–Hood k = 1 with a solid pressure grew 24 → 27 → 34 over the paper's levels 0–2). NGSolve's basis is
hierarchical: its vertex functions are the P1 hat functions and every higher basis function vanishes at the
vertices, so P1 ⊂ P_{k+1} is spanned by the vertex dofs alone, the prolongation from P1 is the injection of the vertex
rows, and the Galerkin coarse matrix Pᵀ A P is A's vertex block. One application (symmetric, so that FGMRES sees a
fixed linear preconditioner):

    y = S b;   y += P A_vv⁻¹ Pᵀ (b − A y);   y += S (b − A y),

S a smoother on all velocity dofs (``velocity_pmg_smooth_``: two symmetric SOR sweeps by default, PETSc's
Richardson with PCSOR, SSOR within each rank) and A_vv⁻¹ one BoomerAMG V-cycle with hypre's elasticity options and the
rigid motions (the near-nullspace's vertex values) attached (``velocity_pmg_coarse_``). Issue 33's prototype: the 3D
solid ball, Taylor–Hood k = 2, levels 0–1, tolerance 1e-12: 47 → 50 iterations become 25 → 26.

MINI's bubbles are cell dofs, one a component, so A's bubble block A_bb is block diagonal and inverted exactly; the
condensed form (`Condensed`, ``velocity_preconditioner = "condensed"``) is A's block factorisation over (bubble,
vertex) with one BoomerAMG cycle on the vertex Schur complement S = A_vv − A_vb A_bb⁻¹ A_bv:

    y_b = A_bb⁻¹ b_b;   y_v = S⁻¹ (b_v − A_vb y_b);   y_b −= A_bb⁻¹ A_bv y_v,

exact where S⁻¹ is (docs/solvers.md, "MINI's bubbles condensed").
"""
from __future__ import annotations

import numpy as np

from ..errors import CaseError
from ..fem.spaces import Spaces
from .petsc_schur import higher_rows

#: The smoother and the coarse solve (keys under the solver's prefix; `petsc.DEFAULTS_PMG`).
SMOOTH = "velocity_pmg_smooth_"
COARSE = "velocity_pmg_coarse_"


class TwoLevel:
    """PETSc's Python PC of the module's docstring on the velocity matrix ``a``: ``vertex`` the index set of its
    vertex rows (the coarse space), reached by a scatter made once (as `Condensed`'s), ``smoother`` a KSP on ``a``,
    ``coarse`` a PC on ``a``'s vertex block."""

    def __init__(self, PETSc, a, vertex, smoother, coarse):
        self.a, self.smoother, self.coarse = a, smoother, coarse
        self._r, self._t = a.createVecs()
        self._rc, self._ec = coarse.getOperators()[0].createVecs()
        self.to_vertex = PETSc.Scatter().create(self._r, vertex, self._rc, None)
        self._prolong = {"addv": PETSc.InsertMode.ADD_VALUES, "mode": PETSc.ScatterMode.REVERSE}

    def apply(self, pc, b, y) -> None:
        a, r, t = self.a, self._r, self._t
        self.smoother.solve(b, y)                    # pre-smoothing from 0
        a.mult(y, r)
        r.aypx(-1.0, b)                              # r = b − A y
        self.to_vertex.scatter(r, self._rc)          # Pᵀ r: the vertex rows
        self.coarse.apply(self._rc, self._ec)
        self.to_vertex.scatter(self._ec, y, **self._prolong)   # y += P e
        a.mult(y, r)
        r.aypx(-1.0, b)
        self.smoother.solve(r, t)                    # post-smoothing
        y.axpy(1.0, t)

    def destroy(self, pc=None) -> None:
        """Free its PETSc objects (by `petsc.PETScSolver.destroy`, or by PETSc with its PC: ``pc``)."""
        for obj in (self._r, self._t, self._rc, self._ec, self.to_vertex, self.smoother, self.coarse):
            obj.destroy()


def vertex_rows(solver, spaces: Spaces, vertex: bool = True) -> np.ndarray:
    """The global numbers (within the velocity field) of this rank's velocity rows that are vertex dofs of V_h (the
    P1 hat functions; with ``vertex`` False the others). Under MPI a rank's rows are not its master dofs
    (`petsc_layout`): the marks travel by a field vector."""
    marks = solver.field_vector((higher_rows(solver, spaces) != vertex).astype(float))
    start = marks.getOwnershipRange()[0]
    rows = start + np.flatnonzero(marks.getArray(readonly=True) > 0.5)
    marks.destroy()
    return rows


def bubble_inverse(PETSc, a_bb, d: int):
    """A_bb⁻¹ as a matrix: MINI's bubbles are cell dofs, one a component, so A_bb is block diagonal (a cell's d × d
    block, its components coupled by ε(v) : ε(w)) and its inverse is the blocks' inverses."""
    a_bb.setBlockSize(d)
    indptr, columns, _ = a_bb.getValuesCSR()
    start, stop = a_bb.getOwnershipRange()
    if np.any(columns // d != np.repeat(np.arange(start, stop), np.diff(indptr)) // d):
        raise CaseError('solver.petsc.velocity_preconditioner: expected "condensed" only with MINI (one bubble a '
                        "cell and component), got a velocity space whose higher dofs couple across cells")
    rows = np.repeat(np.arange(start, stop, d), d)   # each row's block's first column
    return PETSc.Mat().createAIJ(size=a_bb.getSizes(), bsize=d, comm=a_bb.getComm(), csr=(
        np.arange(0, len(rows) * d + 1, d, dtype=PETSc.IntType),
        (rows[:, None] + np.arange(d)).ravel().astype(PETSc.IntType),
        np.asarray(a_bb.invertBlockDiagonal()).ravel()))  # symmetric blocks: row- and column-major alike


class Condensed:
    """PETSc's Python PC of the module's docstring with MINI's bubbles condensed: ``inverse`` A_bb⁻¹, ``a_vb`` and
    ``a_bv`` the velocity block's vertex–bubble blocks, ``coarse`` a PC on the Schur complement S. The ``vertex`` and
    ``bubble`` rows (index sets) of a vector like ``field`` are gathered and put back by scatters made once: the rows
    interleave in PETSc's order (`petsc_layout`), and a sub-vector makes its scatter at every application (0.47
    step-matrix products an application on the 3D fluid ball's level 4)."""

    def __init__(self, PETSc, inverse, a_vb, a_bv, vertex, bubble, coarse, field):
        self.inverse, self.a_vb, self.a_bv, self.coarse = inverse, a_vb, a_bv, coarse
        self._b_v, self._r_v, self._y_v = (a_vb.createVecLeft() for _ in range(3))
        self._b_b, self._y_b, self._t_b = (inverse.createVecLeft() for _ in range(3))
        self.to_vertex = PETSc.Scatter().create(field, vertex, self._b_v, None)
        self.to_bubble = PETSc.Scatter().create(field, bubble, self._b_b, None)
        self._back = {"addv": PETSc.InsertMode.INSERT_VALUES, "mode": PETSc.ScatterMode.REVERSE}

    def apply(self, pc, b, y) -> None:
        b_b, b_v, y_b, y_v = self._b_b, self._b_v, self._y_b, self._y_v
        self.to_bubble.scatter(b, b_b)
        self.to_vertex.scatter(b, b_v)
        self.inverse.mult(b_b, y_b)                 # y_b = A_bb⁻¹ b_b
        self.a_vb.mult(y_b, self._r_v)
        b_v.axpy(-1.0, self._r_v)                   # r_v = b_v − A_vb y_b
        self.coarse.apply(b_v, y_v)                 # y_v = S⁻¹ r_v (one BoomerAMG cycle)
        self.a_bv.mult(y_v, self._t_b)
        self.inverse.mult(self._t_b, b_b)
        y_b.axpy(-1.0, b_b)                         # y_b −= A_bb⁻¹ A_bv y_v
        self.to_bubble.scatter(y_b, y, **self._back)
        self.to_vertex.scatter(y_v, y, **self._back)

    def destroy(self, pc=None) -> None:
        """Free its PETSc objects (as `TwoLevel.destroy`)."""
        for obj in (self._b_v, self._r_v, self._y_v, self._b_b, self._y_b, self._t_b, self.to_vertex, self.to_bubble,
                    self.inverse, self.a_vb, self.a_bv, self.coarse):
            obj.destroy()


def velocity_block(solver, spaces: Spaces) -> TwoLevel | Condensed:
    """The two-level cycle of the module's docstring (``velocity_preconditioner = "p-multigrid"``) or its condensed
    form (``"condensed"``) as PETSc's Python PC of ``solver``'s velocity field (after the fieldsplit's set-up): its
    operators from the step matrix, its options under the solver's prefix."""
    PETSc, (velocity, _) = solver.PETSc, solver.fields
    prefix = solver.ksp.getOptionsPrefix()
    d = spaces.mesh.dim
    nodal = solver.layout.blocksize == d
    a = solver.A.createSubMatrix(velocity, velocity)
    a.setBlockSize(solver.layout.blocksize)
    condensed = solver.options.get("velocity_preconditioner") == "condensed"
    if condensed and not nodal:
        raise CaseError('solver.petsc.velocity_preconditioner: expected "condensed" only where every velocity '
                        "component is free on the same dofs (PETSc's rows node by node), got other dofs per component")

    def index_set(vertex: bool):   # this rank's vertex (else higher) rows as an index set, node by node if nodal
        rows = PETSc.IS().createGeneral(vertex_rows(solver, spaces, vertex).astype(PETSc.IntType), comm=solver.comm)
        if nodal:
            rows.setBlockSize(d)
        return rows

    vertex = index_set(True)
    a_vv = a.createSubMatrix(vertex, vertex)
    if condensed:
        bubble = index_set(False)
        a_bb, a_vb, a_bv = (a.createSubMatrix(rows, columns) for rows, columns in
                            ((bubble, bubble), (vertex, bubble), (bubble, vertex)))
        inverse = bubble_inverse(PETSc, a_bb, d)
        correction = inverse.ptap(a_bv)                          # A_vb A_bb⁻¹ A_bv
        a_vv.axpy(-1.0, correction, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)  # S
        field = a.createVecLeft()
        for obj in (a_bb, correction, a):
            obj.destroy()
    else:
        smoother = PETSc.KSP().create(comm=solver.comm)
        smoother.setOptionsPrefix(prefix + SMOOTH)
        smoother.setOperators(a)
        smoother.setFromOptions()
        smoother.setInitialGuessNonzero(False)
        smoother.setUp()
    if nodal:
        a_vv.setBlockSize(d)
    vectors = []
    for mode in solver.rigid_motion_vectors:
        sub = mode.getSubVector(vertex)
        vector = sub.copy()
        mode.restoreSubVector(vertex, sub)
        for other in vectors:  # modified Gram–Schmidt (the modes vanish on the higher rows: no change but rounding)
            vector.axpy(-vector.dot(other), other)
        vector.normalize()
        vectors.append(vector)
    nullspace = PETSc.NullSpace().create(vectors=vectors, comm=solver.comm)
    a_vv.setNearNullSpace(nullspace)   # after the sum: a new nonzero pattern makes a new matrix
    coarse = PETSc.PC().create(comm=solver.comm)
    coarse.setOptionsPrefix(prefix + COARSE)
    coarse.setOperators(a_vv)
    coarse.setFromOptions()
    coarse.setUp()
    if condensed:
        context = Condensed(PETSc, inverse, a_vb, a_bv, vertex, bubble, coarse, field)
        solver.keep += [vertex, bubble, field, a_vv, nullspace, *vectors]
    else:
        context = TwoLevel(PETSc, a, vertex, smoother, coarse)
        solver.keep += [a, vertex, a_vv, nullspace, *vectors]
    pc = solver.ksp.getPC().getFieldSplitSubKSP()[0].getPC()
    pc.setType("python")
    pc.setPythonContext(context)
    return context
