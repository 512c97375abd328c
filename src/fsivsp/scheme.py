"""The fully discrete scheme: one saddle-point solve per step, then the pointwise stress update —
backward Euler (5.1), the θ-scheme or BDF2 (`timeschemes`), all with one step matrix per run.

Everything that depends only on the mesh and Δt — the step-1 matrix and its solver,
the mass and stiffness operators, the load vectors of time-separable data — is built
once in `Scheme.__init__`; `step` only applies operators to vectors.

Lean operators: the stress update is linear and exact by (18), so with the displacement
uⁿ_h (backward Euler: uⁿ_h = I_h u⁰ + Δt Σ_{k≤n} vᵏ (5)), σⁿ_h = σ*_h + C ε(uⁿ_h), where σ*_h = σ⁰_h − C ε(I_h u⁰)
is zero unless σ⁰_h is the L² projection (26). The terms ∫_S σ:ε(w) of step 1 are b* + K u_h, with
b* = ∫_S σ*_h:ε(w) and K the solid stiffness on the velocity's pattern (`forms.solid_stiffness`). The
scheme keeps no stress-space matrix: σⁿ_h is a CoefficientFunction, formed per cell where it is written
or measured.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import ngsolve as ngs
from ngsolve import InnerProduct, dx, ds

from . import forms
from .fields import Field, TimeVector
from .geometry import FLUID, INTERFACE, SOLID, extent, interface_normal
from .manufactured import grad
from .materials import Materials
from .solvers import SolverError, SolverSpec, compact, factorise, step_solver
from .spaces import Spaces
from .stages import stage
from .threads import current as current_threads, integrate, sequential
from .timeschemes import BDF2, Theta


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


def solver_stage(solver) -> str:
    """The set-up stage of a step solver, e.g. ``factorisation (pardiso)`` or ``preconditioner (minres)``."""
    from .solvers.direct import DirectSolver

    return f"{'factorisation' if isinstance(solver, DirectSolver) else 'preconditioner'} ({solver.method})"


def interpolate(spaces: Spaces, values: ngs.CoefficientFunction) -> ngs.GridFunction:
    """I_h v: nodal P1 interpolation for MINI (bubbles zero, as in the paper's experiment),
    NGSolve's projection-based interpolation for Taylor–Hood."""
    gf = ngs.GridFunction(spaces.velocity)
    if spaces.family == "mini":
        mesh = spaces.mesh
        with sequential():   # the same element colouring in every process (`Set` adds in its order)
            linear = ngs.GridFunction(ngs.VectorH1(mesh, order=1))
        linear.Set(values)
        # The hierarchical H1 basis numbers the vertex dofs first in each component.
        for mine, theirs in zip(gf.components, linear.components):
            mine.vec[: mesh.nv] = theirs.vec
    else:
        gf.Set(values)
    return gf


#: From this many free unknowns on `march` overlaps each solve with the rest of the previous step in
#: a second thread; below, handing the work over (0.1–0.3 ms a step here) costs more than it saves
#: (benchmarks/scheme_timings.py, paper's experiment: 4 407 unknowns 0.97 ms a step against 0.92
#: sequentially, 17 931: 3.1 against 3.4 ms).
MARCH_THREAD_MIN_DOFS = 10_000


#: The Richardson iteration of a start step with another τ (`Scheme._start_solve`) stops when its
#: correction is below this fraction of the solution (contraction 0.28 per iteration for BDF2's start).
START_TOLERANCE = 1e-12
START_MAX_ITERATIONS = 100


class Scheme:
    """A time scheme (`timeschemes`: backward Euler (5.1) by default) for (10) on V_h × Q_h × S_h with the
    decoupled stress update.

    The state is (vⁿ, pⁿ) (``state``) and the displacement uⁿ_h (``displacement``, the velocity part of
    ``carried``); ``stress`` is σⁿ_h = σ*_h + λ div uⁿ_h I + 2μ ε(uⁿ_h), a CoefficientFunction (σ*_h: see the
    module's docstring; a GridFunction on S_h only where σ⁰_h is a projection, else None). BDF2 also keeps
    the level before (``previous``: (vⁿ⁻¹, ·) and (uⁿ⁻¹, 0)); the θ-scheme and BDF2 keep the step's raw
    solution (vⁿ, mⁿ) with the multiplier mⁿ (``solution``), from which pⁿ is formed."""

    def __init__(self, spaces: Spaces, materials: Materials, data: Data, dt: float,
                 solver: SolverSpec | None = None, time_scheme: Theta | BDF2 = Theta()):
        """``solver``: the `SolverSpec` of step 1 (None: the default spec), passed to `solvers.step_solver`;
        ``time_scheme``: `timeschemes.time_scheme`."""
        if dt <= 0:
            raise ValueError(f"dt: expected a positive time step, got {dt}")
        self.spaces, self.materials, self.data, self.dt = spaces, materials, data, dt
        self.time_scheme, self.tau = time_scheme, time_scheme.tau(dt)
        X, dim = spaces.mixed, spaces.mesh.dim

        with stage("assembly"):
            step = forms.step_matrix(spaces, materials, self.tau).Assemble()
            self._matrix = compact(step.mat)
            del step
        with stage("solver") as label:
            self.solver = step_solver(self._matrix, spaces, materials, self.tau, solver)
            label[0] = solver_stage(self.solver)
        self._stiffness = compact(forms.solid_stiffness(spaces, materials).Assemble().mat)
        self._lagged_coefficients = time_scheme.lagged(dt)
        self._lagged = compact(forms.lagged_operator(spaces, materials, *self._lagged_coefficients).Assemble().mat)
        self._viscous = compact(forms.fluid_viscous(spaces, materials).Assemble().mat) \
            if self._lagged_coefficients[1] else None
        self._work = self._matrix.CreateColVector()

        self._loads = self._load_vectors()
        self._dirichlet, self._lifts = self._dirichlet_vectors()

        self.state = ngs.GridFunction(X)       # (vⁿ, pⁿ)
        self.carried = ngs.GridFunction(X)     # (uⁿ_h, 0)
        self.velocity, self.pressure = self.state.components
        self.displacement = self.carried.components[0]
        self.previous = (self.state.vec.CreateVector(), self.state.vec.CreateVector()) \
            if time_scheme.levels == 2 else None
        self.solution = ngs.GridFunction(X) if time_scheme.name != "backward_euler" else None
        self.stress_offset = ngs.GridFunction(spaces.stress) if data.stress0 is not None else None   # σ*_h
        self.stress = forms.elastic_stress(self.displacement, materials, dim)
        if self.stress_offset is not None:
            self.stress = self.stress_offset + self.stress
        self.time, self.n = 0.0, 0
        self._rhs = self.state.vec.CreateVector()
        self._boundary = self.state.vec.CreateVector()
        self._raw = self.state.vec.CreateVector()
        self._explicit = ngs.GridFunction(X)    # ũⁿ
        self._lag_work = None                   # `march`'s second thread's vectors, made on first use
        self._extrapolated = None               # 2Uⁿ − Uⁿ⁻¹ for BDF2's energy, made on first use
        with stage("initial data"):
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
        if d.interface_load is not None and not d.interface_load.is_zero(tuple(zip(*extent(mesh)))):
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

    def _compliance(self, sigma: ngs.CoefficientFunction, tau: ngs.CoefficientFunction) -> ngs.CoefficientFunction:
        """A σ:τ with the compliance A σ = (σ − λ/(dλ + 2μ) tr(σ) I) / (2μ) (elastic energy)."""
        mat, dim = self.materials, self.spaces.mesh.dim
        return (InnerProduct(sigma, tau) - mat.lam / (dim * mat.lam + 2 * mat.mu) * ngs.Trace(sigma) * ngs.Trace(tau)) \
            / (2 * mat.mu)

    # -- state ------------------------------------------------------------------------
    def initialise(self) -> None:
        """v⁰_h = I_h v⁰ or by the projections (22)–(23); u⁰_h = I_h u⁰ (0 if no u⁰ is given); σ⁰_h = C ε(u⁰_h)
        (= M_σ⁻¹C I_h u⁰ by (18), the paper's experiment) or the L² projection (26) of σ⁰, kept as
        σ*_h = σ⁰_h − C ε(u⁰_h); b* = ∫_S σ*_h:ε(w) and the elastic energy of σ*_h."""
        d, spaces = self.data, self.spaces
        self.state.vec[:] = 0.0
        if d.initial_velocity == "projection":
            self.state.vec.data = self._projected_state()
        else:
            self.velocity.vec.data = interpolate(spaces, d.velocity0.coefficient(0.0)).vec
        self.carried.vec[:] = 0.0
        if d.displacement0 is not None:
            self.displacement.vec.data = interpolate(spaces, d.displacement0.coefficient(0.0)).vec
        self._offset_load = self.state.vec.CreateVector()
        self._offset_load[:] = 0.0
        self._offset_energy = 0.0
        if self.stress_offset is not None:
            self._project_offset()
        if self.previous is not None:
            self.previous[0].data = self.state.vec
            self.previous[1].data = self.carried.vec
        if self.solution is not None:
            self._initial_solution()
        self.time, self.n = 0.0, 0

    def _initial_solution(self) -> None:
        """(v⁰, m⁰) with θ m⁰ = p⁰_h, the pressure the first step's extrapolation (`Theta.pressure`) starts
        from: the projection's (22) or the interpolant of p⁰; without p⁰ the first step reports p̂¹."""
        d = self.data
        self.solution.vec.data = self.state.vec
        self._initial_pressure = d.pressure0 is not None
        pressure = self.solution.components[1]
        if d.pressure0 is not None and d.initial_velocity != "projection":
            pressure.Set(d.pressure0.coefficient(0.0))
        pressure.vec.data *= 1.0 / self.time_scheme.start(0).theta

    def _project_offset(self) -> None:
        """σ*_h = Π (σ⁰ − C ε(u⁰_h)) = Π σ⁰ − C ε(u⁰_h) (Π the L² projection (26) onto S_h, cell by cell; exact on
        C ε(u⁰_h) by (18)), b* = ∫_S σ*_h:ε(w) and ∫_S Aσ*_h:σ*_h."""
        spaces, offset, mesh = self.spaces, self.stress_offset, self.spaces.mesh
        solid = mesh.Materials(SOLID)
        offset.Set(self.data.stress0.coefficient(0.0) - forms.elastic_stress(self.displacement, self.materials, mesh.dim),
                   definedon=solid, bonus_intorder=4)
        w, _ = spaces.mixed.TestFunction()
        form = ngs.LinearForm(spaces.mixed)
        form += forms.integral(InnerProduct(offset, forms.eps(w)), spaces, SOLID)
        self._offset_load.data = form.Assemble().vec
        self._offset_energy = integrate(self._compliance(offset, offset), mesh, definedon=solid)

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
        """One step: (vⁿ, mⁿ) from the saddle-point system, then pⁿ and the stress update uⁿ_h = ũⁿ + τ vⁿ."""
        n, current = self.n + 1, self.time_scheme.start(self.n)
        if current.tau(self.dt) != self.tau:
            self._start_solve(current, n, self._raw)
        else:
            self._right_hand_side(current, n, self._rhs, self._boundary)
            self.solver.solve_step(self._rhs, self._boundary, self._raw, self._guess())
        self._accept(self._raw, n, current, None)

    def march(self, steps: int, observe: Callable[[Scheme], None] | None = None) -> None:
        """``steps`` steps, calling ``observe(self)`` after each one with the scheme at that step.

        From `MARCH_THREAD_MIN_DOFS` free unknowns on, a second thread finishes step n while this one
        solves step n + 1: the stress update, ``observe`` (one call at a time and in order; the last in this
        thread) and the part of the next right-hand side without vⁿ⁺¹ (`_lagged_data`).
        Between two solves only the product R vⁿ⁺¹ is left. ``observe`` must not step
        the scheme. The results equal `step` repeated up to round-off (7e-14 relative after 100 steps of the
        paper's experiment, level 4). Only on one thread (`threads.using`): under NGSolve's TaskManager the two
        threads compete for its workers and `step` is faster (100 steps at 17 931 unknowns: 0.33 s against
        0.43 s). A start step with
        another τ (BDF2's first) is taken by `step`."""
        while steps > 0 and self.time_scheme.start(self.n).tau(self.dt) != self.tau:
            self.step()
            steps -= 1
            if observe is not None:
                observe(self)
        if steps <= 0:
            return
        if not self.solver.overlap or self.spaces.free_dofs() < MARCH_THREAD_MIN_DOFS or current_threads() > 1:
            for _ in range(steps):
                self.step()
                if observe is not None:
                    observe(self)
            return
        # step j solves with rhs[j % 2] and boundaries[j % 2] into solutions[j % 2]
        solutions = (self._rhs.CreateVector(), self._rhs.CreateVector())
        rhs = (self._rhs.CreateVector(), self._rhs)
        boundaries = (self._boundary.CreateVector(), self._boundary)
        if self._lag_work is None:
            self._lag_work = (self.state.vec.CreateVector(), ngs.GridFunction(self.spaces.mixed))
        first, scheme, lagged = self.n, self.time_scheme, self._lagged
        _, newest, _, older = scheme.velocity(self.dt)   # the coefficients of vⁿ and vⁿ⁻¹ in aⁿ⁺¹
        # R vʲ, formed for step j + 1's right-hand side, is kept for step j + 2's (BDF2's vⁿ⁻¹ term)
        products = (self._rhs.CreateVector(), self._rhs.CreateVector()) if older else None
        self._right_hand_side(scheme, first + 1, rhs[1], boundaries[1])

        def finish_previous(j: int) -> None:
            if j > 1:
                self._accept(solutions[(j - 1) % 2], first + j - 1, scheme, observe)
            if j < steps:
                self._lagged_data(rhs[(j + 1) % 2], boundaries[(j + 1) % 2], first + j + 1,
                                  products[(j - 1) % 2] if products and j > 1 else None)

        with ThreadPoolExecutor(max_workers=1, thread_name_prefix="fsivsp-march") as second:
            for j in range(1, steps + 1):
                finished = second.submit(finish_previous, j)
                self.solver.solve_step(rhs[j % 2], boundaries[j % 2], solutions[j % 2],
                                       self._guess() if j == 1 else solutions[(j - 1) % 2])
                finished.result()
                if j < steps and products:
                    products[j % 2].data = lagged * solutions[j % 2]
                    rhs[(j + 1) % 2].data += newest * products[j % 2]
                elif j < steps:
                    rhs[(j + 1) % 2].data += newest * (lagged * solutions[j % 2])
        self._accept(solutions[steps % 2], first + steps, scheme, observe)

    def history(self) -> dict[str, ngs.BaseVector]:
        """The vectors that, with n and tₙ, determine every later step (what a checkpoint stores)."""
        vectors = {"state": self.state.vec, "displacement": self.carried.vec}
        if self.previous is not None:
            vectors.update(previous_state=self.previous[0], previous_displacement=self.previous[1])
        if self.solution is not None:
            vectors["solution"] = self.solution.vec
        return vectors

    def _guess(self) -> ngs.BaseVector:
        """Where an iterative solver starts: the last raw solution (vⁿ, mⁿ)."""
        return self.state.vec if self.solution is None else self.solution.vec

    def _combine(self, coefficients, out: ngs.BaseVector) -> None:
        """out = Σ c_k h_k over the history h = (uⁿ, vⁿ, uⁿ⁻¹, vⁿ⁻¹) (``previous`` for the older level)."""
        history = (self.carried.vec, self.state.vec) + (self.previous[::-1] if self.previous else ())
        terms = [(c, h) for c, h in zip(coefficients, history) if c]
        out.data = terms[0][0] * terms[0][1]
        for c, h in terms[1:]:
            out.data += c * h

    def _accept(self, raw: ngs.BaseVector, n: int, current, observe) -> None:
        """Make step n the scheme's state: vⁿ, pⁿ = α mⁿ + β p̂ⁿ⁻¹ (`Theta.pressure`), uⁿ_h = ũⁿ + τ vⁿ
        with ũⁿ from the history before it (`timeschemes`), the history shifted; tₙ; then ``observe``."""
        self._combine(current.explicit(self.dt), self._explicit.vec)
        if self.previous is not None:
            self.previous[0].data = self.state.vec
            self.previous[1].data = self.carried.vec
        self.state.vec.data = raw
        if self.solution is not None:
            alpha, beta = current.pressure(n == 1)
            if n == 1 and not self._initial_pressure:
                self.solution.vec.data = raw    # p⁰ unknown: p̂⁰ := p̂¹, the first step reports p̂¹
            self.pressure.vec.data = alpha * self.pressure.vec + (beta * current.theta) * self.solution.components[1].vec
            self.solution.vec.data = raw
        self.displacement.vec.data = self._explicit.components[0].vec + current.tau(self.dt) * self.velocity.vec
        self.time, self.n = n * self.dt, n
        if observe is not None:
            observe(self)

    def _right_hand_side(self, current, n: int, out: ngs.BaseVector, boundary: ngs.BaseVector,
                         lagged: ngs.BaseMatrix | None = None, lift: bool = True) -> None:
        """Step n's right-hand side, R aⁿ − ω (b* + K eⁿ) + Σ w_j f(t_j) (`timeschemes`), minus the lift of
        the Dirichlet values vⁿ|∂Ω (unless not ``lift``), which go into ``boundary``."""
        dt, work = self.dt, self._work
        self._combine(current.velocity(dt), work)
        out.data = (self._lagged if lagged is None else lagged) * work
        self._combine(current.stiffness(dt), work)
        weight = current.weight(dt)
        out.data -= weight * self._offset_load
        out.data -= weight * (self._stiffness * work)
        self._add_data(out, boundary, current.loads(n, dt), n * dt, lift)

    def _lagged_data(self, out: ngs.BaseVector, boundary: ngs.BaseVector, n: int,
                     product: ngs.BaseVector | None = None) -> None:
        """Into ``out`` step n's right-hand side but for its term in vⁿ⁻¹, while vⁿ⁻¹ is being solved for
        (the history holds level n − 2): with uⁿ⁻¹ = ũⁿ⁻¹ + τ vⁿ⁻¹ the term K eⁿ does not see vⁿ⁻¹
        (e_u τ + e_v = 0), only R aⁿ does. ``product``: R vⁿ⁻² if already formed. The Dirichlet values
        into ``boundary``."""
        scheme, dt = self.time_scheme, self.dt
        work, explicit = self._lag_work
        self._combine(scheme.explicit(dt), explicit.vec)                  # ũⁿ⁻¹
        e = scheme.stiffness(dt)
        work.data = e[0] * explicit.vec
        for c, h in zip(e[2:], (self.carried.vec, self.state.vec)):
            if c:
                work.data += c * h
        weight = scheme.weight(dt)
        out.data = -weight * self._offset_load
        out.data -= weight * (self._stiffness * work)
        a = scheme.velocity(dt)
        if a[3]:
            out.data += a[3] * (self._lagged * self.state.vec if product is None else product)
        self._add_data(out, boundary, scheme.loads(n, dt), n * dt)

    def _add_data(self, rhs: ngs.BaseVector, boundary: ngs.BaseVector, loads: list[tuple[float, float]],
                  time: float, lift: bool = True) -> None:
        """rhs += Σ w_j f(t_j) − A g(time) (the lift, if ``lift``); boundary = g(time), the Dirichlet values."""
        for when, weight in loads:
            for load in self._loads:
                load.add_to(rhs, when, weight)
        if lift:
            for values in self._lifts:
                values.add_to(rhs, time, -1.0)
        boundary[:] = 0.0
        for values in self._dirichlet:
            values.add_to(boundary, time)

    def _start_solve(self, current, n: int, out: ngs.BaseVector) -> None:
        """Step n of ``current``, whose τ' differs from the run's τ (BDF2's Crank–Nicolson start): its
        matrix A(τ') and operator R' are assembled for this step only and A(τ') x = b is solved by Richardson
        x ← x + ω D A(τ)⁻¹ D (b − A(τ') x) with the run's solver, D scaling the pressure by τ/τ' so that D A(τ') D
        has A(τ)'s constraint. Its eigenvalues against A(τ) lie in [r², 1], r = τ'/τ < 1 (the velocity block
        on the discrete kernel, 1 elsewhere), so ω = 2/(1 + r²) contracts by (1 − r²)/(1 + r²) (0.28 for BDF2)."""
        spaces, mat, dt = self.spaces, self.materials, self.dt
        tau = current.tau(dt)
        matrix = compact(forms.step_matrix(spaces, mat, tau).Assemble().mat)
        lagged = compact(forms.lagged_operator(spaces, mat, *current.lagged(dt)).Assemble().mat)
        self._right_hand_side(current, n, self._rhs, self._boundary, lagged, lift=False)
        free = ngs.Projector(spaces.mixed.FreeDofs(), True)
        out.data = self._boundary + free * self._guess()
        residual, correction = out.CreateVector(), out.CreateVector()
        zero = out.CreateVector()
        zero[:] = 0.0
        pressure = slice(spaces.velocity.ndof, spaces.mixed.ndof)
        scale, ratio = self.tau / tau, (tau / self.tau) ** 2
        omega = 2 / (min(1.0, ratio) + max(1.0, ratio))
        for _ in range(START_MAX_ITERATIONS):
            residual.data = self._rhs - matrix * out
            residual.data = free * residual
            residual.FV().NumPy()[pressure] *= scale
            self.solver.solve_step(residual, zero, correction, None)
            correction.FV().NumPy()[pressure] *= scale
            out.data += omega * correction
            if omega * ngs.Norm(correction) <= START_TOLERANCE * ngs.Norm(out):
                return
        raise SolverError(f"the start step ({type(current).__name__} {current.name}, tau {tau:g}) did not "
                          f"converge in {START_MAX_ITERATIONS} Richardson iterations")

    def _energy(self, x: ngs.BaseVector, u: ngs.BaseVector) -> float:
        """½∫ρ|v|² + ½∫_S Aσ:σ of a velocity x and σ = σ*_h + Cε(u): ∫_S Aσ:σ = ∫_S Aσ*_h:σ*_h + 2 b*·u + u·Ku and
        ∫ρ|v|² = v·(R + sK + cK_F)v."""
        s, c = self._lagged_coefficients
        elastic = self._offset_energy + 2 * InnerProduct(self._offset_load, u) + InnerProduct(u, self._stiffness * u)
        kinetic = InnerProduct(x, self._lagged * x) + s * InnerProduct(x, self._stiffness * x)
        if self._viscous is not None:
            kinetic += c * InnerProduct(x, self._viscous * x)
        return 0.5 * (kinetic + elastic)

    def energy(self) -> float:
        """The scheme's stable norm of (vⁿ, σⁿ_h), non-increasing when f = 0 and the boundary is at rest: the
        energy ½∫ρ|vⁿ|² + ½∫_S Aσⁿ_h:σⁿ_h (θ-scheme; conserved up to the viscous dissipation at θ = 1/2) or
        BDF2's G-norm ½(E(Uⁿ) + E(2Uⁿ − Uⁿ⁻¹)), U = (v, σ), from n = 1 on: at n = 1 it exceeds E⁰ by
        E(U¹ − U⁰) (the Crank–Nicolson start's level n − 1 is U⁰)."""
        if self.previous is None or self.n == 0:
            return self._energy(self.state.vec, self.carried.vec)
        if self._extrapolated is None:
            self._extrapolated = (self.state.vec.CreateVector(), self.state.vec.CreateVector())
        x, u = self._extrapolated
        x.data = 2 * self.state.vec - self.previous[0]
        u.data = 2 * self.carried.vec - self.previous[1]
        return 0.5 * (self._energy(self.state.vec, self.carried.vec) + self._energy(x, u))
