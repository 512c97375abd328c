"""The fully discrete scheme (5.1): backward Euler, one saddle-point solve per step,
then the pointwise stress update.

Everything that depends only on the mesh and Δt — the step-1 matrix and its
factorisation, the mass and coupling operators, the load vectors of time-separable
data — is built once in `BackwardEuler.__init__`; `step` only applies operators to
vectors.
"""
from __future__ import annotations

import functools
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import scipy.sparse as sp
import ngsolve as ngs
from ngsolve import InnerProduct, dx, ds

from . import forms
from .fields import Field, TimeVector
from .geometry import FLUID, INTERFACE, SOLID, interface_normal
from .manufactured import grad
from .materials import Materials
from .solvers import MAX_ITERATIONS, TOLERANCE, compact, factorise, step_solver, to_ngsolve, to_scipy_csr
from .spaces import Spaces


#: How σ⁰_h and v⁰_h are built (see `Data`): the paper's experiment first, then the analysis' projections.
INITIAL_STRESS = ("displacement", "projection")
INITIAL_VELOCITY = ("interpolation", "projection")


@dataclass
class Data:
    """Data of the model (1)–(3) as fields of x, y, z, t.

    ``boundary_velocity`` maps boundary names (``"a|b"`` allowed) to Dirichlet data,
    ``boundary_traction`` to prescribed σn, ``interface_load`` is a tensor J whose
    traction J n (n from Ω_F into Ω_S) loads Γ as ∫_Γ J n·w (for a manufactured
    solution J = σ_F − σ_S, see `manufactured`). The initial stress is built from
    ``displacement0`` (σ⁰ = λ div(I_h u⁰) I + 2μ ε(I_h u⁰), the paper's experiment) or,
    if given, is the L² projection (26) of ``stress0``. The initial velocity is the nodal
    interpolant of ``velocity0`` (``initial_velocity = "interpolation"``, the paper's experiment)
    or its projection (22)–(23) together with ``pressure0`` (``"projection"``, the analysis' choice).
    """

    velocity0: Field
    pressure0: Field | None = None
    initial_velocity: str = "interpolation"
    displacement0: Field | None = None
    stress0: Field | None = None
    force_fluid: Field | None = None
    force_solid: Field | None = None
    boundary_velocity: dict[str, Field] = field(default_factory=dict)
    boundary_traction: dict[str, Field] = field(default_factory=dict)
    interface_load: Field | None = None

    def __post_init__(self):
        if self.initial_velocity not in INITIAL_VELOCITY:
            raise ValueError(f"initial_velocity: expected one of {', '.join(INITIAL_VELOCITY)}, "
                             f"got {self.initial_velocity!r}")


def interpolate(spaces: Spaces, values: ngs.CoefficientFunction) -> ngs.GridFunction:
    """I_h v: nodal P1 interpolation for MINI (bubbles zero, as in the paper's experiment),
    NGSolve's projection-based interpolation for Taylor–Hood."""
    gf = ngs.GridFunction(spaces.velocity)
    if spaces.family == "mini":
        mesh = spaces.mesh
        linear = ngs.GridFunction(ngs.VectorH1(mesh, order=1))
        linear.Set(values)
        # The hierarchical H1 basis numbers the vertex dofs first in each component.
        for mine, theirs in zip(gf.components, linear.components):
            mine.vec[: mesh.nv] = theirs.vec
    else:
        gf.Set(values)
    return gf


def block_inverse(mass: ngs.BaseMatrix, space: ngs.FESpace) -> ngs.BaseMatrix:
    """The inverse of the mass matrix of a discontinuous space, one dense block per cell."""
    cells = np.array([el.dofs for el in space.Elements(ngs.VOL) if len(el.dofs) and min(el.dofs) >= 0])
    n, size = cells.shape
    rows = np.repeat(cells, size, axis=1).reshape(n, size, size)
    cols = np.tile(cells, size).reshape(n, size, size)
    blocks = np.linalg.inv(np.asarray(to_scipy_csr(mass)[rows.ravel(), cols.ravel()]).reshape(n, size, size))
    return to_ngsolve(sp.csr_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())), shape=(mass.height, mass.width)))


#: From this many free unknowns on `march` overlaps each solve with the rest of the previous step in
#: a second thread; below, handing the work over (0.1–0.3 ms a step here) costs more than it saves
#: (benchmarks/scheme_timings.py, paper's experiment: 4 407 unknowns 0.97 ms a step against 0.92
#: sequentially, 17 931: 3.1 against 3.4 ms).
MARCH_THREAD_MIN_DOFS = 10_000


class BackwardEuler:
    """Backward Euler for (10) on V_h × Q_h × S_h with the decoupled stress update (5.1)."""

    def __init__(self, spaces: Spaces, materials: Materials, data: Data, dt: float,
                 solver: str | None = None, track_displacement: bool = False, tolerance: float = TOLERANCE,
                 max_iterations: int = MAX_ITERATIONS):
        """``solver``: a name `solvers.step_solver` accepts (None: ``"auto"``); ``tolerance`` and
        ``max_iterations`` are the iterative solver's."""
        if dt <= 0:
            raise ValueError(f"dt: expected a positive time step, got {dt}")
        self.spaces, self.materials, self.data, self.dt = spaces, materials, data, dt
        X, S = spaces.mixed, spaces.stress

        step = forms.step_matrix(spaces, materials, dt).Assemble()
        self._matrix = step.mat
        self.solver = step_solver(step.mat, spaces, materials, dt, solver, tolerance, max_iterations)
        self._mass = compact(forms.velocity_mass(spaces, materials).Assemble().mat)
        self._divergence = compact(forms.stress_divergence(spaces).Assemble().mat)
        rate = forms.stress_rate(spaces, materials).Assemble().mat
        self._stress_inverse = block_inverse(forms.stress_mass(spaces).Assemble().mat, S)
        update = to_scipy_csr(self._stress_inverse) @ to_scipy_csr(rate)  # M_σ⁻¹C
        update.eliminate_zeros()
        self._stress_update = to_ngsolve(update)
        if spaces.free_dofs() >= MARCH_THREAD_MIN_DOFS:
            self._lagged_mass  # built here with the other operators, not in `march`'s first step
        self._compliance = self._compliance_matrix()

        self._loads = self._load_vectors()
        self._dirichlet, self._lifts = self._dirichlet_vectors()

        self.state = ngs.GridFunction(X)       # (vⁿ, pⁿ)
        self.stress = ngs.GridFunction(S)      # σⁿ
        self.velocity, self.pressure = self.state.components
        self.displacement = ngs.GridFunction(spaces.velocity) if track_displacement else None
        self.time, self.n = 0.0, 0
        self._rhs = self.state.vec.CreateVector()
        self._boundary = self.state.vec.CreateVector()
        self.initialise()

    # -- precomputation -------------------------------------------------------------
    def _linear_form(self, integrand: Callable, measure) -> Callable:
        """image(cf) for `TimeVector`: the load ∫ integrand(cf, w) over ``measure``."""
        w, _ = self.spaces.mixed.TestFunction()

        def image(cf):
            form = ngs.LinearForm(self.spaces.mixed)
            form += integrand(cf, w) * measure
            return lambda: form.Assemble().vec

        return image

    def _load_vectors(self) -> list[TimeVector]:
        """∫_F f_F·w + ∫_S f_S·w + Σ ∫_{Γ_N} t·w + ∫_Γ (J n)·w, each a `TimeVector`."""
        d, mesh = self.data, self.spaces.mesh
        order = forms.DATA_BONUS
        dot = lambda cf, w: InnerProduct(cf, w)
        loads = []
        if d.force_fluid is not None:
            fluid = dx(FLUID, bonus_intorder=order + self.spaces.bonus_intorder)
            loads.append(TimeVector(d.force_fluid, self._linear_form(dot, fluid)))
        if d.force_solid is not None:
            loads.append(TimeVector(d.force_solid, self._linear_form(dot, dx(SOLID, bonus_intorder=order))))
        for name, traction in d.boundary_traction.items():
            loads.append(TimeVector(traction, self._linear_form(dot, ds(name, bonus_intorder=order))))
        if d.interface_load is not None and not d.interface_load.is_zero():
            n = interface_normal(mesh)
            loads.append(TimeVector(d.interface_load,
                                    self._linear_form(lambda J, w: InnerProduct(J * n, w),
                                                      ds(INTERFACE, bonus_intorder=order))))
        return loads

    def _dirichlet_vectors(self) -> tuple[list[TimeVector], list[TimeVector]]:
        """Boundary values g(t) of the velocity (each dof owned by the first boundary naming it)
        and their images A g(t) under the step matrix, which lift them into the right-hand side."""
        mesh, V = self.spaces.mesh, self.spaces.velocity
        owned = ngs.BitArray(self.spaces.mixed.ndof)
        owned.Clear()
        vectors, lifts = [], []
        for names, values in self.data.boundary_velocity.items():
            region = mesh.Boundaries(names)
            mine = ngs.BitArray(self.spaces.mixed.ndof)
            mine.Clear()
            for el in mesh.Elements(ngs.BND):
                if region.Mask()[el.index]:
                    for dof in V.GetDofNrs(el):
                        if dof >= 0 and not owned[dof]:
                            mine.Set(dof)
            owned = owned | mine
            image = self._boundary_image(region, mine)
            vectors.append(TimeVector(values, image))
            lifts.append(TimeVector(values, lambda cf, image=image: self._lift(image(cf))))
        return vectors, lifts

    def _lift(self, boundary_values: Callable) -> Callable:
        lifted = self._matrix.CreateColVector()

        def compute():
            lifted.data = self._matrix * boundary_values()
            return lifted

        return compute

    def _boundary_image(self, region, mine: ngs.BitArray) -> Callable:
        def image(cf):
            gf = ngs.GridFunction(self.spaces.mixed)
            others = ~np.array([mine[i] for i in range(len(mine))], dtype=bool)

            def compute():
                gf.components[0].Set(cf, ngs.BND, definedon=region)
                gf.vec.FV().NumPy()[others] = 0.0
                return gf.vec

            return compute

        return image

    def _compliance_matrix(self) -> ngs.BaseMatrix:
        """∫_S A σ:τ with the compliance A σ = (σ − λ/(dλ + 2μ) tr(σ) I) / (2μ) (elastic energy)."""
        S, mat, dim = self.spaces.stress, self.materials, self.spaces.mesh.dim
        sigma, tau = S.TnT()
        a = ngs.BilinearForm(S)
        a += (InnerProduct(sigma, tau) - mat.lam / (dim * mat.lam + 2 * mat.mu) * ngs.Trace(sigma) * ngs.Trace(tau)) \
            / (2 * mat.mu) * dx(SOLID)
        return compact(a.Assemble().mat)

    # -- state ------------------------------------------------------------------------
    def initialise(self) -> None:
        """v⁰_h = I_h v⁰ or by the projections (22)–(23), σ⁰_h from the interpolated displacement or
        by the L² projection (26)."""
        d, S = self.data, self.spaces.stress
        self.state.vec[:] = 0.0
        if d.initial_velocity == "projection":
            self.state.vec.data = self._projected_state()
        else:
            self.velocity.vec.data = interpolate(self.spaces, d.velocity0.coefficient(0.0)).vec
        self.stress.vec[:] = 0.0
        u0 = None
        if d.displacement0 is not None:
            u0 = interpolate(self.spaces, d.displacement0.coefficient(0.0))
        if d.stress0 is not None:
            tau = S.TestFunction()
            load = ngs.LinearForm(S)
            load += InnerProduct(d.stress0.coefficient(0.0), tau) * dx(SOLID, bonus_intorder=4)
            self.stress.vec.data = self._stress_inverse * load.Assemble().vec
        elif u0 is not None:
            displacement = self.state.vec.CreateVector()
            displacement[:] = 0.0
            displacement[: len(u0.vec)] = u0.vec  # V_h is the first block of X_h
            self.stress.vec.data = self._stress_update * displacement
        if self.displacement is not None:
            self.displacement.vec[:] = 0.0
            if u0 is not None:
                self.displacement.vec.data = u0.vec
        self.time, self.n = 0.0, 0

    def _projected_state(self) -> ngs.BaseVector:
        """(v⁰_h, p⁰_h) from `forms.initial_projection` (Stokes (22) on Ω_F, H¹ (23) on Ω_S),
        with v⁰ as Dirichlet values on ∂Ω; p⁰ = 0 if not given."""
        d, spaces, dim = self.data, self.spaces, self.spaces.mesh.dim
        gradient = grad(d.velocity0.components(), dim)
        pressure = d.pressure0.coefficient(0.0) if d.pressure0 is not None else ngs.CoefficientFunction(0.0)
        matrix = forms.initial_projection(spaces, self.materials).Assemble().mat
        load = forms.initial_projection_load(spaces, self.materials, Field(gradient).coefficient(0.0), pressure)
        rhs = load.Assemble().vec
        state = self.state.vec.CreateVector()
        state[:] = 0.0
        for values in self._dirichlet:
            values.add_to(state, 0.0)
        rhs.data -= matrix * state
        state.data += factorise(matrix, spaces.mixed.FreeDofs()).inverse * rhs
        return state

    def step(self) -> None:
        """One step of (5.1): (vⁿ, pⁿ) from the saddle-point system, then
        σⁿ = σⁿ⁻¹ + Δt (λ div vⁿ I + 2μ ε(vⁿ)) exactly (condition (18))."""
        time = (self.n + 1) * self.dt  # no accumulated round-off in tₙ = nΔt
        self.right_hand_side(time)
        self.solve()
        self.update_stress()
        self.time, self.n = time, self.n + 1

    def march(self, steps: int, observe: Callable[[BackwardEuler], None] | None = None) -> None:
        """``steps`` steps of (5.1), calling ``observe(self)`` after each one with the scheme at that step.

        From `MARCH_THREAD_MIN_DOFS` free unknowns on, a second thread finishes step n while this one
        solves step n + 1: the stress update σⁿ = σⁿ⁻¹ + Δt M_σ⁻¹C vⁿ, ``observe`` (one call at a time
        and in order; the last in this thread) and the part of the next right-hand side without vⁿ⁺¹
        (`_lagged_data`).
        Between two solves only the product (M − Δt² B M_σ⁻¹C) vⁿ⁺¹ is left. ``observe`` must not step
        the scheme. The results equal `step` repeated up to round-off (7e-14 relative after 100 steps of the
        paper's experiment, level 4). Under NGSolve's TaskManager the two threads compete for its workers:
        `step` is faster there (100 steps at 17 931 unknowns: 0.33 s against 0.43 s)."""
        if steps <= 0:
            return
        if self.spaces.free_dofs() < MARCH_THREAD_MIN_DOFS:
            for _ in range(steps):
                self.step()
                if observe is not None:
                    observe(self)
            return
        # step j solves with rhs[j % 2] and boundaries[j % 2] into solutions[j % 2]
        solutions = (self._rhs.CreateVector(), self._rhs.CreateVector())
        rhs = (self._rhs.CreateVector(), self._rhs)
        boundaries = (self._boundary.CreateVector(), self._boundary)
        first, lagged_mass = self.n, self._lagged_mass
        self.right_hand_side((first + 1) * self.dt)

        def finish_previous(j: int) -> None:
            if j > 1:
                self._accept(solutions[(j - 1) % 2], first + j - 1, observe)
            if j < steps:
                self._lagged_data(rhs[(j + 1) % 2], boundaries[(j + 1) % 2], (first + j + 1) * self.dt)

        with ThreadPoolExecutor(max_workers=1, thread_name_prefix="fsivsp-march") as second:
            for j in range(1, steps + 1):
                finished = second.submit(finish_previous, j)
                self.solve(solutions[j % 2], rhs[j % 2], boundaries[j % 2],
                           self.state.vec if j == 1 else solutions[(j - 1) % 2])
                finished.result()
                if j < steps:
                    rhs[(j + 1) % 2].data += lagged_mass * solutions[j % 2]
        self._accept(solutions[steps % 2], first + steps, observe)

    @functools.cached_property
    def _lagged_mass(self) -> ngs.BaseMatrix:
        """M − Δt² B M_σ⁻¹C, so that M vⁿ − Δt B σⁿ = (M − Δt² B M_σ⁻¹C) vⁿ − Δt B σⁿ⁻¹ (B M_σ⁻¹C is
        ∫_S Cε(v):ε(w)). Only a threaded `march` uses it, so it is built only where `march` threads
        (0.21 s and 854 306 entries at level 4 of the paper's experiment)."""
        lagged = to_scipy_csr(self._mass) - self.dt**2 * (to_scipy_csr(self._divergence)
                                                          @ to_scipy_csr(self._stress_update))
        lagged.eliminate_zeros()
        return to_ngsolve(lagged)

    def _accept(self, solution: ngs.BaseVector, n: int, observe) -> None:
        """Make step n the scheme's state: (vⁿ, pⁿ), σⁿ, tₙ; then ``observe``."""
        self.state.vec.data = solution
        self.update_stress()
        self.time, self.n = n * self.dt, n
        if observe is not None:
            observe(self)

    def _lagged_data(self, out: ngs.BaseVector, boundary: ngs.BaseVector, time: float) -> None:
        """Into ``out`` the right-hand side at ``time`` but for its term (M − Δt² B M_σ⁻¹C) v of the step
        before: −Δt B σ with the current σ, the loads and the lifts; the Dirichlet values into ``boundary``."""
        out.data = -self.dt * (self._divergence * self.stress.vec)
        self._add_data(out, boundary, time)

    def right_hand_side(self, time: float) -> None:
        """Step 1's right-hand side, Δt f(tₙ) + ρ vⁿ⁻¹ − Δt σⁿ⁻¹:ε(·), minus the lift of the
        Dirichlet values vⁿ|∂Ω; the lift itself is kept in the boundary vector."""
        self._rhs.data = self._mass * self.state.vec
        self._rhs.data -= self.dt * (self._divergence * self.stress.vec)
        self._add_data(self._rhs, self._boundary, time)

    def _add_data(self, rhs: ngs.BaseVector, boundary: ngs.BaseVector, time: float) -> None:
        """rhs += Δt f(time) − A g(time); boundary = g(time), the Dirichlet values."""
        for load in self._loads:
            load.add_to(rhs, time, self.dt)
        for lift in self._lifts:
            lift.add_to(rhs, time, -1.0)
        boundary[:] = 0.0
        for values in self._dirichlet:
            values.add_to(boundary, time)

    def solve(self, out: ngs.BaseVector | None = None, rhs: ngs.BaseVector | None = None,
              boundary: ngs.BaseVector | None = None, previous: ngs.BaseVector | None = None) -> None:
        """(vⁿ, pⁿ) = lift + A_ff⁻¹ rhs with the solver built once (``previous``, the step before, starts an
        iterative solver); by default from the vectors of `right_hand_side` into the state."""
        out = self.state.vec if out is None else out
        self.solver.solve_step(self._rhs if rhs is None else rhs, self._boundary if boundary is None else boundary,
                               out, self.state.vec if previous is None else previous)

    def update_stress(self) -> None:
        """Step 2 of (5.1), and the displacement (5) if tracked."""
        self.stress.vec.data += self.dt * (self._stress_update * self.state.vec)
        if self.displacement is not None:
            self.displacement.vec.data += self.dt * self.velocity.vec

    def energy(self) -> float:
        """½∫ρ|vⁿ|² + ½∫_S Aσⁿ:σⁿ; non-increasing when f = 0 and the boundary is at rest."""
        x, s = self.state.vec, self.stress.vec
        return 0.5 * (InnerProduct(x, self._mass * x) + InnerProduct(s, self._compliance * s))
