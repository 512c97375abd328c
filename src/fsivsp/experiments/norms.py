"""Errors against an exact solution, in the norms of Section 5.3, at O(unknowns) per step.

For an exact field E(x, t) = Σ_k T_k(t) E_k(x) and a Hilbert norm with Gram matrix G,
let π_k be the G-orthogonal projection of E_k onto the discrete space. For every
discrete u_h, by orthogonality,

    ‖E(t) − u_h‖² = Σ_kl T_k(t) T_l(t) r_kl + ‖Σ_k T_k(t) π_k − u_h‖²_G,
    r_kl = (E_k − π_k, E_l − π_l).

The r_kl are integrated once, with a high-order rule applied to the differences (no
cancellation), and each step costs one product with G. Fields that do not separate in
time fall back to quadrature at every step.
"""
from __future__ import annotations

from collections.abc import Callable

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp
import sympy

from ..fem.forms import DATA_BONUS, region_integral
from ..geometry import FLUID, SOLID, Phases, pattern
from ..model.expressions import SPACE, separate_time_vector, to_coefficient, to_function
from ..runtime.threads import integrate
from ..solvers import compact
from .projection import gram_solver

# A norm is a sum of parts ∫_region op(u)·op(u): (region or None for Ω, op on discrete functions, op on exact fields).
Part = tuple[str | None, Callable, Callable]


def h1_component(j: int, dim: int) -> list[Part]:
    """‖v_j‖²_{H¹(Ω)} = ‖v_j‖²_{L²(Ω)} + ‖∇v_j‖²_{L²(Ω)}, the j-th velocity component."""
    return [
        (None, lambda u: u[j], lambda e: e),
        (None, lambda u: ngs.Grad(u)[j, :], lambda e: [sympy.diff(e, s) for s in SPACE[:dim]]),
    ]


def l2(region: str) -> list[Part]:
    """‖·‖²_{L²(region)} of a scalar or tensor field."""
    return [(region, lambda u: u, lambda e: e)]


def component(i: int) -> Callable:
    """Selector of the i-th unknown of a product space (trial/test tuples and GridFunctions alike)."""
    return lambda f: f.components[i] if isinstance(f, ngs.GridFunction) else f[i]


def whole(f):
    """Selector of the only unknown of a plain space."""
    return f


def _components(expr) -> list[sympy.Expr]:
    return list(expr) if isinstance(expr, sympy.MatrixBase) else [expr]


def _shaped(expr, comps):
    return sympy.Matrix(expr.rows, expr.cols, comps) if isinstance(expr, sympy.MatrixBase) else comps[0]


def _integral(integrand, region, bonus: int, phases: Phases):
    """∫_region integrand (Ω if None) with ``DATA_BONUS`` extra quadrature order everywhere and
    ``bonus`` more on the fluid cells (where bubbles live, see `Spaces.bonus_intorder`). The Gram
    matrices and the projections of the exact fields both use it: with different rules a field that
    lies in the discrete space is not projected onto itself (on curved cells the integrands are
    rational, and the error norm had a floor of 5e-8)."""
    return region_integral(integrand, region, bonus, DATA_BONUS, phases)


def region_pattern(region: str | None, phases: Phases) -> str | None:
    """The cell-region pattern of a `Part`'s region: Ω_F, Ω_S of ``phases`` for `FLUID`, `SOLID`, else itself."""
    return phases.pattern(region) if region in (FLUID, SOLID) else region


def gram_matrix(space: ngs.FESpace, members: list[tuple[Callable, list[Part]]], bonus: int = 0,
                phases: Phases = Phases()) -> ngs.BaseMatrix:
    """The Gram matrix of the sum of the norms (select, parts) on ``space``."""
    gram = ngs.BilinearForm(space, symmetric=True)
    for select, parts in members:
        u, w = (select(f) for f in space.TnT())
        for region, op, _ in parts:
            gram += _integral(ngs.InnerProduct(op(u), op(w)), region, bonus, phases)
    return compact(gram.Assemble().mat)


def connected_parts(mesh: ngs.Mesh, regions: tuple[str, ...]) -> np.ndarray:
    """The connected part (0, 1, …; cells sharing a vertex) of each vertex of the cell ``regions``, −1 elsewhere."""
    import scipy.sparse.csgraph as csgraph

    elements = (mesh.ngmesh.Elements3D() if mesh.dim == 3 else mesh.ngmesh.Elements2D()).NumPy()
    names = mesh.GetMaterials()
    mine = np.isin(elements["index"], [i + 1 for i, name in enumerate(names) if name in regions])
    nodes = elements["nodes"][mine][:, : mesh.dim + 1].astype(np.int64) - 1
    cells = np.repeat(np.arange(len(nodes)), nodes.shape[1])
    incidence = sp.csr_matrix((np.ones(nodes.size), (cells, nodes.ravel())), shape=(len(nodes), mesh.nv))
    _, labels = csgraph.connected_components(incidence @ incidence.T, directed=False)
    part = np.full(mesh.nv, -1)
    part[nodes.ravel()] = np.repeat(labels, nodes.shape[1])
    return part


def rigid_motions(space: ngs.FESpace, select: Callable, regions: tuple[str, ...]) -> list[ngs.BaseVector]:
    """The kernel of ε on the cell ``regions``: translations and rotations of each connected part of them,
    interpolated (exactly: they are affine) in the unknown ``select`` picks, zero elsewhere."""
    mesh = space.mesh
    x, y, z = ngs.x, ngs.y, ngs.z
    fields = [(1, 0), (0, 1), (-y, x)] if mesh.dim == 2 else \
        [(1, 0, 0), (0, 1, 0), (0, 0, 1), (-y, x, 0), (-z, 0, x), (0, -z, y)]
    part = connected_parts(mesh, regions)
    parts = part.max(initial=-1) + 1  # none on a rank without cells of the region (MPI)
    owner = None
    if parts > 1:  # the part of each dof, from the cells of the region
        owner = np.full(space.ndof, -1)
        for el in mesh.Elements(ngs.VOL):
            if el.mat in regions:
                owner[[d for d in space.GetDofNrs(el) if d >= 0]] = part[el.vertices[0].nr]
    motions = []
    for field in fields:
        gf = ngs.GridFunction(space)
        select(gf).Set(ngs.CF(field), definedon=mesh.Materials(pattern(regions)))
        for k in range(parts):
            vector = gf.vec.CreateVector()
            vector.data = gf.vec
            if owner is not None:
                vector.FV().NumPy()[owner != k] = 0.0
            motions.append(vector)
    return motions


class ErrorNorm:
    """t ↦ ‖E(t) − offset − op(u_h)‖ for one unknown.

    ``select`` picks the unknown out of the space's trial/test functions and
    GridFunctions: `component` (i) for a product space such as X_h = V_h × Q_h, `whole` otherwise.
    ``offset`` (one part only) is a fixed discrete field subtracted from the exact one: the stress
    σ_h = σ*_h + Cε(u_h) of the lean scheme is measured with op = Cε on the displacement u_h.
    """

    def __init__(self, space: ngs.FESpace, select: Callable, parts: list[Part], exact, intorder: int, bonus: int = 0,
                 offset: ngs.CoefficientFunction | None = None, kernel: list[ngs.BaseVector] | None = None,
                 phases: Phases = Phases(), quadrature: bool = False):
        """``intorder``: quadrature order for the exact field; ``bonus``: see `Spaces.bonus_intorder`;
        ``kernel``: a basis of the kernel of the Gram matrix on the dofs it sees (Cε: `rigid_motions`). The
        projections are then solved for the singular G (`projection.gram_solver`), and Σ T_k π_k − u_h is cleared of its
        kernel part before the product with G, which would otherwise leave a floor of about 1e-9 ‖E‖ (the
        rounding of G times an O(1) rigid motion, squared and rooted). ``quadrature``: by quadrature at every
        evaluation, as fields that do not separate in time (for a G whose kernel is not known: the stress
        2μ ε(u) − P I of a solid pressure vanishes on the dilation u = x with P = 2μ as on the rigid motions)."""
        if offset is not None and len(parts) != 1:
            raise ValueError("ErrorNorm: an offset needs a norm of one part")
        self.space, self.select, self.parts, self.exact, self.intorder = space, select, parts, exact, intorder
        self.bonus, self.offset, self.phases = bonus, offset, phases
        w = select(space.TestFunction())
        terms = separate_time_vector(_components(exact))
        # MPI: quadrature; the Gram solve runs distributed (`solvers.symmetric`), but the used dofs, the kernel
        # (`rigid_motions` by each rank's connected parts) and `NormGroup`'s partial products here are local
        if quadrature:
            terms = None
        else:
            self._gram = gram_matrix(space, [(select, parts)], bonus, phases)
            self._diff = self._gram.CreateColVector()
            self._work = self._gram.CreateColVector()
        if terms is None or space.ParallelDofs() is not None:
            self._time = ngs.Parameter(0.0)
            self._uh = ngs.GridFunction(space)
            self._integrand = self._remainder(self._offset(self._exact_cfs(exact, self._time)), self._uh)
            self._terms = None
            return
        self._terms = [(to_function(tk), self._exact_cfs(_shaped(exact, sk), 0.0)) for tk, sk in terms]
        if offset is not None:
            self._terms.append((lambda t: 1.0, [-offset]))
        used = self._used_dofs()
        dofs = np.flatnonzero(used)
        contiguous = len(dofs) and dofs[-1] - dofs[0] + 1 == len(dofs)
        self.dofs = slice(int(dofs[0]), int(dofs[-1]) + 1) if contiguous else dofs  # a view where possible
        self._kernel = None if kernel is None else np.linalg.qr(
            np.column_stack([k.FV().NumPy()[self.dofs] for k in kernel]))[0]
        project = gram_solver(self._gram, space, used, None if kernel is None else (self._kernel, self.dofs))
        self._projections = []
        for _, cfs in self._terms:
            load = ngs.LinearForm(space)
            for (region, op, _), cf in zip(parts, cfs):
                load += _integral(ngs.InnerProduct(cf, op(w)), region, bonus, phases)
            pi = ngs.GridFunction(space)
            project(load.Assemble().vec, pi.vec)
            self._projections.append(pi)
        remainders = [self._remainder(cfs, pi) for (_, cfs), pi in zip(self._terms, self._projections)]
        k = len(self._terms)
        self._residual = np.zeros((k, k))
        for a in range(k):
            for b in range(a, k):
                self._residual[a, b] = self._residual[b, a] = sum(
                    self._integrate(ra * rb if ra.dim == 1 else ngs.InnerProduct(ra, rb), region)
                    for (ra, region), (rb, _) in zip(remainders[a], remainders[b]))

    def _offset(self, cfs: list) -> list:
        return cfs if self.offset is None else [cfs[0] - self.offset]

    def _integrate(self, cf, region) -> float:
        mesh = self.space.mesh
        where = region_pattern(region, self.phases)
        return integrate(cf, mesh, definedon=mesh.Materials(where) if where else None, order=self.intorder)

    def _used_dofs(self) -> np.ndarray:
        """The dofs the norm sees (nonzero diagonal of G), as a mask."""
        rows, cols, vals = (np.asarray(a) for a in self._gram.COO())
        used = np.zeros(self.space.ndof, dtype=bool)
        used[rows[(rows == cols) & (vals > 0)]] = True
        return used

    def _exact_cfs(self, expr, t):
        return [to_coefficient(exact_op(expr), t).Compile() for _, _, exact_op in self.parts]

    def _remainder(self, cfs, gf: ngs.GridFunction):
        discrete = self.select(gf)
        return [(cf - op(discrete), region) for cf, (region, op, _) in zip(cfs, self.parts)]

    @property
    def separable(self) -> bool:
        return self._terms is not None

    def add_projection(self, out: ngs.BaseVector, time: float) -> float:
        """out += Σ_k T_k(time) π_k; returns Σ_kl T_k T_l r_kl."""
        coeffs = np.array([fn(time) for fn, _ in self._terms])
        for c, pi in zip(coeffs, self._projections):
            out.data += float(c) * pi.vec
        return float(coeffs @ self._residual @ coeffs)

    def by_quadrature(self, uh: ngs.BaseVector, time: float) -> float:
        """‖E(time) − u_h‖² by quadrature (fields that do not separate in time)."""
        self._time.Set(time)
        self._uh.vec.data = uh
        return sum(self._integrate(e * e if e.dim == 1 else ngs.InnerProduct(e, e), region)
                   for e, region in self._integrand)

    def __call__(self, uh: ngs.BaseVector, time: float) -> float:
        """‖E(time) − u_h‖ for the coefficient vector ``uh`` of the space."""
        if self._terms is None:
            return float(np.sqrt(max(self.by_quadrature(uh, time), 0.0)))
        self._diff.data = -uh
        remainder = self.add_projection(self._diff, time)
        if self._kernel is not None:
            seen = self._diff.FV().NumPy()[self.dofs]  # a view for a contiguous range
            seen -= self._kernel @ (self._kernel.T @ seen)
            self._diff.FV().NumPy()[self.dofs] = seen
        self._work.data = self._gram * self._diff
        return float(np.sqrt(max(remainder + ngs.InnerProduct(self._diff, self._work), 0.0)))


class NormGroup:
    """Several `ErrorNorm` of unknowns of one space with disjoint dofs (v₁, v₂, p of X_h),
    evaluated together: one vector Σ T_k π_k − u_h, one product with the summed Gram matrix,
    and a partial inner product per unknown."""

    def __init__(self, norms: dict[str, ErrorNorm]):
        self.norms = norms
        space = next(iter(norms.values())).space
        self._gram = gram_matrix(space, [(n.select, n.parts) for n in norms.values() if n.separable],
                                 max(n.bonus for n in norms.values()), next(iter(norms.values())).phases)
        self._diff = self._gram.CreateColVector()
        self._work = self._gram.CreateColVector()

    def __call__(self, uh: ngs.BaseVector, time: float) -> dict[str, float]:
        """{name: ‖E(time) − u_h‖}."""
        self._diff.data = -uh
        squares = {name: norm.add_projection(self._diff, time) if norm.separable else norm.by_quadrature(uh, time)
                   for name, norm in self.norms.items()}
        self._work.data = self._gram * self._diff
        d, w = self._diff.FV().NumPy(), self._work.FV().NumPy()
        for name, norm in self.norms.items():
            if norm.separable:  # einsum, not BLAS: OpenBLAS's spinning threads would slow `march`'s solve
                squares[name] += float(np.einsum("i,i", d[norm.dofs], w[norm.dofs]))
        return {name: float(np.sqrt(max(value, 0.0))) for name, value in squares.items()}
