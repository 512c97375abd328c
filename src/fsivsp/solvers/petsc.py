"""The PETSc backend for step 1 of (5.1): a Krylov method with a PCFIELDSPLIT Schur-complement preconditioner.

The step matrix on the free dofs is [[A, C^T], [C, 0]], C = −ΔtB, A = ρM + 2νΔt K_F + Δt²(2μ K_S + λ D_S)
(`forms.step_matrix`). PETSc sees it as one AIJ matrix with two named fields:

- ``velocity``: A⁻¹ by algebraic multigrid, GAMG with the rigid motions as near-nullspace (the kernel of ε, in
  the fluid and the solid alike), on the velocity dofs ordered node by node (block size d);
- ``pressure``: the Schur complement S = −C A⁻¹ Cᵀ by Cahouet–Chabard, S⁻¹ ≈ −(F_ρ⁻¹ + 2ν/Δt M_p⁻¹) with
  F_ρ = C diag(ρM)⁻¹ Cᵀ (the pressure Laplacian of the discrete B, inertia-dominated limit: one AMG cycle) and
  M_p the pressure mass (viscosity-dominated limit: its diagonal), `CahouetChabard` below.

The Krylov method is FGMRES on the unpreconditioned residual, stopped at ``tol`` times ‖b‖. Every choice is a
PETSc option under the prefix ``fsivsp_`` (`DEFAULTS`), overridden by the case file's ``[solver.petsc]`` table
or ``--petsc-options``, e.g. ``-fsivsp_ksp_monitor`` or ``-fsivsp_fieldsplit_velocity_pc_type hypre``.
"""
from __future__ import annotations

import atexit
import time
import weakref
from typing import Mapping

import numpy as np
import ngsolve as ngs

from .. import forms
from ..materials import Materials
from ..spaces import Spaces
from .direct import SolverError, free_mask, to_scipy_csr
from .iterative import NotConverged

PREFIX = "fsivsp_"

#: The measured defaults (docs/solvers.md, "PETSc"). Keys without the prefix; values as PETSc reads them.
DEFAULTS: dict[str, str] = {
    "ksp_type": "fgmres",
    "ksp_gmres_restart": "100",
    "ksp_pc_side": "right",
    "pc_type": "fieldsplit",
    "pc_fieldsplit_type": "schur",
    "pc_fieldsplit_schur_fact_type": "upper",
    "pc_fieldsplit_schur_precondition": "selfp",
    "fieldsplit_velocity_ksp_type": "preonly",
    "fieldsplit_velocity_pc_type": "hypre",
    "fieldsplit_pressure_ksp_type": "preonly",
    "schur_approximation": "lsc",
    "schur_laplacian_pc_type": "hypre",
    "schur_laplacian_pc_hypre_boomeramg_max_iter": "2",
}

#: BoomerAMG on the velocity in 3D: the settings for 3D elasticity-like systems (strong threshold 0.5, HMIS
#: coarsening, ext+i interpolation with at most 4 entries per row, aggressive coarsening on the first level):
#: on level 3 of the 3D fluid ball 14 iterations at 17 ms per V-cycle against 10 at 64 ms with hypre's
#: defaults. In 2D the defaults are better (the paper's levels 2-4: 13, 16, 21 iterations against 24, 30, 37).
DEFAULTS_3D: dict[str, str] = {
    "fieldsplit_velocity_pc_hypre_boomeramg_strong_threshold": "0.5",
    "fieldsplit_velocity_pc_hypre_boomeramg_coarsen_type": "HMIS",
    "fieldsplit_velocity_pc_hypre_boomeramg_interp_type": "ext+i",
    "fieldsplit_velocity_pc_hypre_boomeramg_P_max": "4",
    "fieldsplit_velocity_pc_hypre_boomeramg_agg_nl": "1",
    "fieldsplit_velocity_pc_hypre_boomeramg_relax_type_all": "l1scaled-SOR/Jacobi",
}


def available() -> str | None:
    """None if petsc4py imports here, else why not (one line)."""
    try:
        import petsc4py  # noqa: F401
        from petsc4py import PETSc  # noqa: F401
    except ImportError as error:
        return (f"petsc4py does not import ({error}): on Debian or Ubuntu 'make install' installs it "
                "(python3-petsc4py-real); elsewhere 'conda install -c conda-forge petsc4py'")
    return None


#: The solvers alive: their PETSc objects are destroyed before PETSc finalises at exit (after, a destructor
#: that reaches PETSc crashes the process).
_LIVE: "weakref.WeakSet[PETScSolver]" = weakref.WeakSet()


def _petsc():
    reason = available()
    if reason:
        raise SolverError(f"solver: 'petsc' is unavailable: {reason}")
    import petsc4py

    if not _LIVE and not getattr(_petsc, "initialised", False):
        petsc4py.init()
        atexit.register(lambda: [solver.destroy() for solver in list(_LIVE)])
        _petsc.initialised = True
    from petsc4py import PETSc

    return PETSc


def rigid_motions(points: np.ndarray) -> np.ndarray:
    """The rigid motions at ``points`` (n × d) as columns of an (n·d × m) array, node by node (x₁, y₁[, z₁],
    x₂, …): d translations and d(d−1)/2 rotations about the centroid, orthonormalised."""
    n, d = points.shape
    x = points - points.mean(axis=0)
    modes = [np.zeros((n, d)) for _ in range(d + d * (d - 1) // 2)]
    for j in range(d):
        modes[j][:, j] = 1.0
    for k, (a, b) in enumerate([(0, 1)] if d == 2 else [(0, 1), (1, 2), (2, 0)]):
        modes[d + k][:, a], modes[d + k][:, b] = -x[:, b], x[:, a]
    basis = np.column_stack([m.ravel() for m in modes])
    return np.linalg.qr(basis)[0]


class SchurPreconditioner:
    """PETSc's Python PC for the pressure block, −S⁻¹ ≈ −(L⁻¹ R L⁻¹ + w ∘) (see the module's docstring): ``L`` a
    pressure Laplacian applied by ``cycles`` AMG cycles (an inner PC under the prefix ``prefix``), ``R`` a sparse
    matrix (None: the identity, one cycle of L⁻¹ and no second), ``weight`` a diagonal (None: none)."""

    def __init__(self, PETSc, laplacian, middle, weight, prefix: str):
        self.amg = PETSc.PC().create(comm=laplacian.getComm())
        self.amg.setOptionsPrefix(prefix)
        self.amg.setOperators(laplacian)
        self.amg.setFromOptions()
        self.amg.setUp()
        self.middle, self.weight = middle, weight
        self._u, self._v = laplacian.createVecs()

    def apply(self, pc, x, y) -> None:
        if self.middle is None:
            self.amg.apply(x, y)
        else:
            self.amg.apply(x, self._u)
            self.middle.mult(self._u, self._v)
            self.amg.apply(self._v, y)
        if self.weight is not None:
            self._u.pointwiseMult(self.weight, x)
            y.axpy(1.0, self._u)
        y.scale(-1.0)


def least_squares_commutator(step, nvel: int, higher: np.ndarray, corrected: bool):
    """(F, Yᵀ A Y − C) of `schur.LeastSquaresCommutator` from the step matrix on the free dofs (scipy, PETSc's
    order): D = diag(A), Y = D⁻¹ Cᵀ, F = C Y; ``higher`` marks the velocity's higher-order dofs, whose term
    the correction C = Y_hᵀ A_hh Y_h − F_h diag(F_h)⁻¹ F_h replaces where ``corrected``."""
    import scipy.sparse as sp

    a, c = step[:nvel, :nvel].tocsr(), step[nvel:, :nvel].tocsr()
    y = (sp.diags(1.0 / a.diagonal()) @ c.T).tocsr()
    f = (c @ y).tocsr()
    middle = (y.T @ (a @ y)).tocsr()
    if corrected and higher.any():
        y_h = (sp.diags(higher.astype(float)) @ y).tocsr()
        f_h = (c @ y_h).tocsr()
        scale = f_h.diagonal()
        scale = np.where(scale > 0, 1.0 / np.where(scale > 0, scale, 1.0), 0.0)
        middle = (middle - y_h.T @ (a @ y_h) + f_h @ sp.diags(scale) @ f_h).tocsr()
    return f, middle


class PETScSolver:
    """Step 1 by PETSc's KSP with the fieldsplit preconditioner of the module's docstring.

    ``solve_step(rhs, boundary, out, guess)`` sets ``out = boundary + A_ff⁻¹ rhs`` from the free part of
    ``guess``; raises `NotConverged` when PETSc's KSP stops without reaching ``tol`` ‖b‖.
    """

    method = "petsc"
    overlap = True

    def __init__(self, matrix: ngs.BaseMatrix, spaces: Spaces, materials: Materials, dt: float, tol: float,
                 maxiter: int, options: Mapping[str, object] | None = None):
        if not 0 < tol < 1:
            raise ValueError(f"tolerance: expected a number in (0, 1), got {tol!r}")
        PETSc = _petsc()
        start = time.perf_counter()
        self.PETSc, self.tol, self.maxiter = PETSc, tol, maxiter
        X, V = spaces.mixed, spaces.velocity
        free = free_mask(X.FreeDofs(), X.ndof)
        self.order, blocksize = self._ordering(spaces, free)
        nvel = int(np.count_nonzero(self.order < V.ndof))
        full = to_scipy_csr(matrix)
        step = full[self.order][:, self.order].tocsr()
        self.A = self._mat(step)
        velocity = PETSc.IS().createStride(nvel, 0, 1, comm=PETSc.COMM_SELF)
        velocity.setBlockSize(blocksize)
        pressure = PETSc.IS().createStride(len(self.order) - nvel, nvel, 1, comm=PETSc.COMM_SELF)
        velocity.compose("nearnullspace", self._near_nullspace(spaces, nvel, blocksize))

        defaults = {**DEFAULTS, **(DEFAULTS_3D if spaces.mesh.dim == 3 else {})}
        self.options = self._set_options(PETSc, defaults, options or {})
        self.ksp = PETSc.KSP().create(comm=PETSc.COMM_SELF)
        self.ksp.setOptionsPrefix(PREFIX)
        self.ksp.setOperators(self.A)
        pc = self.ksp.getPC()
        pc.setType("fieldsplit")
        pc.setFieldSplitIS(("velocity", velocity), ("pressure", pressure))
        self.ksp.setFromOptions()
        self.ksp.setTolerances(rtol=tol, atol=0.0, max_it=maxiter)  # the case's tolerance over ksp_rtol
        self.ksp.setInitialGuessNonzero(True)
        self.ksp.setUp()  # creates the fieldsplit's sub-KSPs, whose pressure PC is set below
        if self.options.get("pc_fieldsplit_type") == "schur" and self.options["schur_approximation"] != "petsc":
            self._pressure_preconditioner(spaces, materials, dt, step, nvel)
        self.ksp.setUp()
        if pc.getType() == "fieldsplit":
            for block in pc.getFieldSplitSubKSP():  # else PETSc sets up the AMG at the first solve
                block.setUp()
        self._clear_options()
        self._b, self._x = self.A.createVecs()
        _LIVE.add(self)
        self.iterations: list[int] = []
        self.residual = float("nan")
        self.factor_seconds = time.perf_counter() - start

    def _set_options(self, PETSc, defaults: dict[str, str], options: Mapping[str, object]) -> dict[str, str]:
        """Enter ``defaults`` (`DEFAULTS`, `DEFAULTS_3D`), then ``options`` (the case file's or the command line's), into PETSc's options
        database under `PREFIX`; what the user set there already (PETSC_OPTIONS) is kept. Returns the
        options in force."""
        database = PETSc.Options()
        given = {str(k).lstrip("-").removeprefix(PREFIX): v for k, v in options.items()}
        entered = []
        for key, value in {**defaults, **given}.items():
            if key in given or not database.hasName(PREFIX + key):
                database[PREFIX + key] = "" if value is True else str(value)
                entered.append(PREFIX + key)
        self._entered = entered
        return {key: database.getString(PREFIX + key, "") for key in {**defaults, **given}}

    def _clear_options(self) -> None:
        """Take this solver's entries out of PETSc's options database again (it is one per process: the next
        solver, another level or another case, starts from PETSC_OPTIONS and its own options only)."""
        database = self.PETSc.Options()
        for name in self._entered:
            database.delValue(name)

    @staticmethod
    def _ordering(spaces: Spaces, free: np.ndarray) -> tuple[np.ndarray, int]:
        """The free dofs in PETSc's order: the velocity node by node (block size d) where every component is
        free on the same scalar dofs, else component by component (block size 1); then the pressure."""
        V, d = spaces.velocity, spaces.mesh.dim
        scalar = V.ndof // d
        components = free[:V.ndof].reshape(d, scalar)
        pressure = np.flatnonzero(free[V.ndof:]) + V.ndof
        if (components == components[0]).all():
            nodes = np.flatnonzero(components[0])
            velocity = (np.arange(d)[None, :] * scalar + nodes[:, None]).ravel()
            return np.concatenate([velocity, pressure]), d
        return np.concatenate([np.flatnonzero(free[:V.ndof]), pressure]), 1

    def _mat(self, csr):
        PETSc = self.PETSc
        return PETSc.Mat().createAIJ(size=csr.shape, csr=(csr.indptr.astype(PETSc.IntType),
                                                          csr.indices.astype(PETSc.IntType), csr.data),
                                     comm=PETSc.COMM_SELF)

    def _near_nullspace(self, spaces: Spaces, nvel: int, blocksize: int):
        """The rigid motions on the velocity field: their vertex values (the hierarchical basis's higher dofs
        of a linear field vanish), zero elsewhere."""
        PETSc, mesh, V = self.PETSc, spaces.mesh, spaces.velocity
        d, scalar = mesh.dim, V.ndof // mesh.dim
        points = np.array([v.point for v in mesh.vertices])
        modes = rigid_motions(points).reshape(mesh.nv, d, -1)  # (vertex, component, mode)
        velocity = self.order[:nvel]
        component, node = np.divmod(velocity, scalar)
        values = np.zeros((nvel, modes.shape[2]))
        vertex = node < mesh.nv
        values[vertex] = modes[node[vertex], component[vertex]]
        values = np.linalg.qr(values)[0]
        vectors = []
        for column in values.T:
            vec = PETSc.Vec().createWithArray(np.ascontiguousarray(column), comm=PETSc.COMM_SELF)
            vec.setBlockSize(blocksize)
            vectors.append(vec)
        return PETSc.NullSpace().create(vectors=vectors, comm=PETSc.COMM_SELF)

    def _pressure_preconditioner(self, spaces: Spaces, materials: Materials, dt: float, step, nvel: int) -> None:
        """The pressure block as PETSc's Python PC: the least-squares commutator (``schur_approximation =
        lsc``, the default) or Cahouet–Chabard (``cahouet-chabard``), see the module's docstring."""
        PETSc = self.PETSc
        if self.options["schur_approximation"] == "lsc":
            corrected = spaces.family == "mini" or spaces.order == 1
            f, middle = least_squares_commutator(step, nvel, self._higher(spaces, nvel), corrected)
            self._keep = [self._mat(f), self._mat(middle)]
            context = SchurPreconditioner(PETSc, self._keep[0], self._keep[1], None, PREFIX + "schur_laplacian_")
        else:
            X = spaces.mixed
            (v, p), (w, q) = X.TnT()
            mass = forms.velocity_mass(spaces, materials)
            mass.Assemble()
            pmass = ngs.BilinearForm(X)
            pmass += forms.pressure_mass(p, q)
            pmass.Assemble()
            rho = to_scipy_csr(mass.mat).diagonal()[self.order[:nvel]]
            coupling = step[nvel:, :nvel].tocsr()
            laplacian = (coupling @ (coupling.T.multiply(1.0 / rho[:, None]))).tocsr()
            weight = PETSc.Vec().createWithArray(2 * materials.nu / dt
                                                 / to_scipy_csr(pmass.mat).diagonal()[self.order[nvel:]])
            self._keep = [self._mat(laplacian), weight]
            context = SchurPreconditioner(PETSc, self._keep[0], None, weight, PREFIX + "schur_laplacian_")
        pc = self.ksp.getPC().getFieldSplitSubKSP()[1].getPC()
        pc.setType("python")
        pc.setPythonContext(context)
        self._schur = context

    def _higher(self, spaces: Spaces, nvel: int) -> np.ndarray:
        """Which of PETSc's velocity dofs are not vertex dofs (MINI's bubbles, Taylor–Hood's higher dofs)."""
        scalar = spaces.velocity.ndof // spaces.mesh.dim
        return self.order[:nvel] % scalar >= spaces.mesh.nv

    def solve_step(self, rhs: ngs.BaseVector, boundary: ngs.BaseVector, out: ngs.BaseVector,
                   guess: ngs.BaseVector | None = None) -> None:
        """out = boundary + A_ff⁻¹ rhs (``guess`` may be ``out`` itself)."""
        self._b.setArray(rhs.FV().NumPy()[self.order])
        if guess is None:
            self._x.set(0.0)
        else:
            self._x.setArray(guess.FV().NumPy()[self.order])
        self.ksp.solve(self._b, self._x)
        self.iterations.append(self.ksp.getIterationNumber())
        norm = self._b.norm()
        self.residual = self.ksp.getResidualNorm() / norm if norm > 0 else 0.0
        if self.ksp.getConvergedReason() < 0:
            raise NotConverged(f"petsc: {self.ksp.getType()} did not reach the tolerance {self.tol:g} in "
                               f"{self.iterations[-1]} iterations (relative residual {self.residual:.2e}, "
                               f"reason {self.ksp.getConvergedReason()})")
        values = boundary.FV().NumPy().copy()
        values[self.order] += self._x.getArray()
        out.FV().NumPy()[:] = values

    def destroy(self) -> None:
        """Free the PETSc objects (`_LIVE`: at exit, before PETSc finalises)."""
        for obj in (self.ksp, self.A, self._b, self._x, *getattr(self, "_keep", ())):
            obj.destroy()
        if getattr(self, "_schur", None) is not None:
            self._schur.amg.destroy()
        _LIVE.discard(self)

    def progress(self) -> str:
        return f"PETSc {self.iterations[-1] if self.iterations else 0} its"

    def statistics(self) -> dict:
        counts = self.iterations or [0]
        return {"method": self.method, "tolerance": self.tol, "residual": self.residual,
                "setup_seconds": self.factor_seconds,
                "preconditioner": {"ksp": self.options["ksp_type"], "pc": "fieldsplit "
                                   + self.options.get("pc_fieldsplit_type", ""),
                                   "velocity": self.options.get("fieldsplit_velocity_pc_type"),
                                   "pressure": self.options["schur_approximation"]},
                "iterations": {"mean": float(np.mean(counts)), "max": int(max(counts)), "solves": len(self.iterations)}}
