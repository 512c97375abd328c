"""The fully discrete scheme: one saddle-point solve per step, then the pointwise stress update —
backward Euler (5.1), the θ-scheme or BDF2 (`timeschemes`), all with one step matrix per run.

Everything that depends only on the mesh and Δt — the step-1 matrix and its solver,
the mass and stiffness operators, the load vectors of time-separable data (`loads`) — is built
once in `Scheme.__init__`; `step` only applies operators to vectors. The initial state (22)–(26) is
`initial`'s, the time loop with its overlapping thread `marching`'s.

Lean operators: the stress update is linear and exact by (18), so with the displacement
uⁿ_h (backward Euler: uⁿ_h = I_h u⁰ + Δt Σ_{k≤n} vᵏ (5)), σⁿ_h = σ*_h + C ε(uⁿ_h), where σ*_h = σ⁰_h − C ε(I_h u⁰)
is zero unless σ⁰_h is the L² projection (26). The terms ∫_S σ:ε(w) of step 1 are b* + K u_h, with
b* = ∫_S σ*_h:ε(w) and K the solid stiffness on the velocity's pattern (`forms.solid_stiffness`). The
scheme keeps no stress-space matrix: σⁿ_h is a CoefficientFunction, formed per cell where it is written
or measured.

The boundary conditions beyond velocity and traction keep one matrix per run: a tissue support is part of K and
K_F (`forms.boundary_mass`), a flow-rate inflow part of the Dirichlet data (`fem.inflow`), and each lumped outlet a
rank-one term γ c cᵀ of the step matrix, solved by the Woodbury formula around the run's solver
(`solvers.woodbury`) with its lumped model in `outlets`.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable

import ngsolve as ngs
import numpy as np
from ngsolve import InnerProduct

from ..fem import forms
from ..fem.inflow import flux_vector
from ..fem.loads import Loads
from ..fem.spaces import Spaces
from ..model.data import Data
from ..model.materials import Materials
from ..runtime import threads
from ..runtime.logs import stage
from ..solvers import AUTO, UNDAMPED_REDUCTION, SolverError, SolverSpec, auto_target, compact, solver_kind, step_solver
from ..solvers.woodbury import WoodburySolver
from .initial import initial_multiplier, initial_solid_pressure, initial_state, project_offset
from .marching import march
from .outlets import STATE, Outlet
from .schemes import BDF2, Theta
from .warmstart import MinimalResidualStart, takes_start


def solver_stage(solver) -> str:
    """The set-up stage of a step solver, e.g. ``factorisation (pardiso)`` or ``preconditioner (petsc)``."""
    from ..solvers.direct import DirectSolver

    return f"{'factorisation' if isinstance(solver, DirectSolver) else 'preconditioner'} ({solver.method})"


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
    solution (vⁿ, mⁿ) with the multiplier mⁿ (``solution``), from which pⁿ is formed. ``materials`` are the
    data's, ``coefficients`` what the forms multiply in (`forms.coefficients`); ``outlets`` the lumped outlets
    (`outlets.Outlet`) with their flux vectors ``flux_vectors``, ``inflows`` the flow-rate inflows
    (`fem.inflow.FlowInflow`) by boundary."""

    def __init__(self, spaces: Spaces, materials: Materials, data: Data, dt: float,
                 solver: SolverSpec | None = None, time_scheme: Theta | BDF2 = Theta()):
        """``solver``: the `SolverSpec` of step 1 (None: the default spec), passed to `solvers.step_solver`;
        ``time_scheme``: `timeschemes.time_scheme`. A run on the default threads takes one for a small problem
        and for a 2D factorisation (`threads.fit`)."""
        if dt <= 0:
            raise ValueError(f"dt: expected a positive time step, got {dt}")
        unknowns, dim = spaces.free_dofs(), spaces.mesh.dim
        solver = solver or SolverSpec()
        if not time_scheme.damps:   # Crank–Nicolson: the auto tolerance's tighter reduction
            solver = dataclasses.replace(solver, reduction=UNDAMPED_REDUCTION)
        threads.fit(unknowns, dim, solver_kind(solver, unknowns, dim))
        #: the auto tolerance's ρ (`solvers.base.auto_target`), None for a fixed tolerance
        self.reduction = solver.reduction if solver.tolerance == AUTO else None
        self.spaces, self.materials, self.data, self.dt = spaces, materials, data, dt
        self.time_scheme, self.tau = time_scheme, time_scheme.tau(dt)
        self.pressure_unit = self.tau   # ϑ: a solid pressure's unknowns are ϑπ and ϑP (`forms`)
        X, dim = spaces.mixed, spaces.mesh.dim
        self.coefficients = mat = forms.coefficients(materials, spaces)
        supports = data.supports
        self._outlet_state = np.zeros((len(data.outlets), len(STATE)))
        self.outlets = [Outlet(name, model, state) for (name, model), state in zip(data.outlets.items(),
                                                                                   self._outlet_state)]

        with stage("assembly"):
            step = forms.step_matrix(spaces, mat, self.tau, supports, unit=self.pressure_unit).Assemble()
            self._matrix = compact(step.mat, symmetric=spaces.periodic)
            del step
            self.flux_vectors = [flux_vector(spaces, outlet.name) for outlet in self.outlets]
        with stage("solver") as label:
            self.solver = step_solver(self._matrix, spaces, mat, self.tau, solver)
            label[0] = solver_stage(self.solver)
            if self.outlets:
                self.solver = WoodburySolver(self.solver, self.flux_vectors,
                                             [outlet.weight(time_scheme, dt) for outlet in self.outlets],
                                             X.FreeDofs())
        self._stiffness = compact(forms.solid_stiffness(spaces, mat, supports, self.pressure_unit).Assemble().mat)
        self._lagged_coefficients = time_scheme.lagged(dt)
        self._lagged = compact(forms.lagged_operator(spaces, mat, *self._lagged_coefficients, supports,
                                                     self.pressure_unit).Assemble().mat)
        self._viscous = compact(forms.fluid_viscous(spaces, mat, supports).Assemble().mat) \
            if self._lagged_coefficients[1] else None
        self._work = self._matrix.CreateColVector()

        self.loads = Loads(spaces, data, self._matrix, materials)
        self.inflows = self.loads.inflows

        self.state = ngs.GridFunction(X)       # (vⁿ, pⁿ), and ϑπⁿ with a solid pressure
        self.carried = ngs.GridFunction(X)     # (uⁿ_h, 0), and ϑPⁿ with a solid pressure
        self.velocity, self.pressure = self.state.components[:2]
        self.displacement = self.carried.components[0]
        #: ϑPⁿ (a GridFunction on P_h), None without a solid pressure
        self.solid_pressure = self.carried.components[2] if spaces.solid_pressure is not None else None
        self.previous = (self.state.vec.CreateVector(), self.state.vec.CreateVector()) \
            if time_scheme.levels == 2 else None
        self.solution = ngs.GridFunction(X) if time_scheme.name != "backward_euler" else None
        self.stress_offset = ngs.GridFunction(spaces.stress) if data.stress0 is not None else None   # σ*_h
        self._discrete_stress = forms.elastic_stress(self.displacement, mat, dim) if self.solid_pressure is None else \
            forms.solid_stress(self.displacement, (1 / self.pressure_unit) * self.solid_pressure, mat, dim)
        self.stress = self._discrete_stress
        if self.stress_offset is not None:
            self.stress = self.stress_offset + self.stress
        self.time, self.n = 0.0, 0
        self._rhs = self.state.vec.CreateVector()
        self._boundary = self.state.vec.CreateVector()
        self._raw = self.state.vec.CreateVector()
        self._explicit = ngs.GridFunction(X)    # ũⁿ
        self._extrapolated = None               # 2Uⁿ − Uⁿ⁻¹ for BDF2's energy, made on first use
        #: the last solutions, where an iterative solve starts (`warmstart`)
        self.warm = MinimalResidualStart(self.state.vec, self._matrix, X.FreeDofs(), takes_start(self.solver),
                                         time_scheme.damps, self.solver.add_terms if self.outlets else None)
        with stage("initial data"):
            self.initialise()

    def initialise(self) -> None:
        """v⁰_h = I_h v⁰ or by the projections (22)–(23); u⁰_h = I_h u⁰ (0 if no u⁰ is given); σ⁰_h = C ε(u⁰_h)
        (= M_σ⁻¹C I_h u⁰ by (18), the paper's experiment) or the L² projection (26) of σ⁰, kept as
        σ*_h = σ⁰_h − C ε(u⁰_h); b* = ∫_S σ*_h:ε(w) and the elastic energy of σ*_h (`initial`)."""
        d, spaces = self.data, self.spaces
        initial_state(spaces, self.coefficients, d, self.loads.dirichlet, self.state, self.carried)
        if self.solid_pressure is not None:
            initial_solid_pressure(spaces, self.coefficients, self.pressure_unit, d, self.state, self.carried)
        self._offset_load = self.state.vec.CreateVector()
        self._offset_load[:] = 0.0
        self._offset_energy = 0.0
        if self.stress_offset is not None:
            self._offset_energy = project_offset(spaces, self.coefficients, d.stress0, self._discrete_stress,
                                                 self.stress_offset, self._offset_load)
        for outlet, flow in zip(self.outlets, self.outlet_flows()):
            outlet.start(flow)
        if self.previous is not None:
            self.previous[0].data = self.state.vec
            self.previous[1].data = self.carried.vec
        if self.solution is not None:
            self._initial_pressure = d.pressure0 is not None
            initial_multiplier(d, self.state.vec, self.solution, self.time_scheme.start(0).theta)
        self.warm.reset(self.latest())
        self.time, self.n = 0.0, 0

    def step(self) -> None:
        """One step: (vⁿ, mⁿ) from the saddle-point system, then pⁿ and the stress update uⁿ_h = ũⁿ + τ vⁿ."""
        n, current = self.n + 1, self.time_scheme.start(self.n)
        if current.tau(self.dt) != self.tau:
            self._start_solve(current, n, self._raw)
        else:
            self.right_hand_side(current, n, self._rhs, self._boundary)
            self.solve(self._rhs, self._boundary, self._raw, self.n)
        self.warm.record(self._raw)
        self.accept(self._raw, n, current, None)

    def solve(self, rhs: ngs.BaseVector, boundary: ngs.BaseVector, out: ngs.BaseVector, n: int) -> None:
        """Step n + 1's solve (1) into ``out`` from the start of `warmstart`; its solution is not yet recorded for
        the next start (`MinimalResidualStart.record`)."""
        start, reference = self.warm.start(self.time_scheme, n, rhs)
        target = auto_target(self.reduction, reference, self.warm.predicts(self.time_scheme, n))
        self.solver.solve_step(rhs, boundary, out, start, target)

    def march(self, steps: int, observe: Callable[[Scheme], None] | None = None) -> None:
        """``steps`` steps, calling ``observe(self)`` after each one with the scheme at that step; from
        `marching.MARCH_THREAD_MIN_DOFS` unknowns on, each solve beside the rest of the step before
        (`marching.march`)."""
        march(self, steps, observe)

    def history(self) -> dict[str, ngs.BaseVector | np.ndarray]:
        """The vectors that, with n and tₙ, determine every later step (what a checkpoint stores), the raw solutions
        before xⁿ included (where the iterative solver starts, `warmstart`: bit for bit on resuming); the outlets'
        states (P_cⁿ, P_cⁿ⁻¹, Qⁿ each, the same on every rank) and the start's count as arrays."""
        vectors = {"state": self.state.vec, "displacement": self.carried.vec}
        if self.previous is not None:
            vectors.update(previous_state=self.previous[0], previous_displacement=self.previous[1])
        if self.solution is not None:
            vectors["solution"] = self.solution.vec
        vectors.update(self.warm.history())
        if self.outlets:
            vectors["outlets"] = self._outlet_state
        return vectors

    @property
    def step_matrix(self) -> ngs.BaseMatrix:
        """The step matrix A of (5.1) (its τ the run's), on X_h."""
        return self._matrix

    def outlet_flows(self, x: ngs.BaseVector | None = None) -> list[float]:
        """Q = cᵀx through each outlet (x: the state (vⁿ, pⁿ) by default)."""
        x = self.state.vec if x is None else x
        return [InnerProduct(c, x) for c in self.flux_vectors]

    # -- the step's pieces, which `step` and `marching` drive ------------------------------------------
    def latest(self) -> ngs.BaseVector:
        """The last raw solution xⁿ: (vⁿ, pⁿ), or (vⁿ, mⁿ) with the multiplier mⁿ."""
        return self.state.vec if self.solution is None else self.solution.vec

    def guess(self) -> ngs.BaseVector:
        """The reference start of step n + 1: 2xⁿ − xⁿ⁻¹ (`warmstart`), or xⁿ."""
        return self.warm.reference(self.time_scheme, self.n)

    def restored(self, missing: set[str]) -> None:
        """After a checkpoint's vectors were loaded into `history`'s, without the ``missing`` ones (an older
        format): the start's history completed and its products made again (`warmstart`)."""
        self.warm.restored(self.latest(), missing)

    def _combine(self, coefficients, out: ngs.BaseVector) -> None:
        """out = Σ c_k h_k over the history h = (uⁿ, vⁿ, uⁿ⁻¹, vⁿ⁻¹) (``previous`` for the older level)."""
        history = (self.carried.vec, self.state.vec) + (self.previous[::-1] if self.previous else ())
        terms = [(c, h) for c, h in zip(coefficients, history) if c]
        out.data = terms[0][0] * terms[0][1]
        for c, h in terms[1:]:
            out.data += c * h

    def accept(self, raw: ngs.BaseVector, n: int, current, observe) -> None:
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
            self.pressure.vec.data = (alpha * self.pressure.vec
                                      + (beta * current.theta) * self.solution.components[1].vec)
            self.solution.vec.data = raw
        self.displacement.vec.data = self._explicit.components[0].vec + current.tau(self.dt) * self.velocity.vec
        if self.solid_pressure is not None:   # ϑPⁿ = ϑP̃ⁿ + τ ϑπⁿ, as the displacement
            self.solid_pressure.vec.data = (self._explicit.components[2].vec
                                            + current.tau(self.dt) * self.state.components[2].vec)
        for outlet, flow in zip(self.outlets, self.outlet_flows()):
            outlet.accept(n, flow)
        self.time, self.n = n * self.dt, n
        if observe is not None:
            observe(self)

    def right_hand_side(self, current, n: int, out: ngs.BaseVector, boundary: ngs.BaseVector,
                        lagged: ngs.BaseMatrix | None = None, lift: bool = True) -> None:
        """Step n's right-hand side, R aⁿ − ω (b* + K eⁿ) + Σ w_j f(t_j) (`timeschemes`) − Σ_i s_i c_i (the
        outlets', `outlets.Outlet.load`), minus the lift of the Dirichlet values vⁿ|∂Ω (unless not ``lift``), which
        go into ``boundary``."""
        dt, work = self.dt, self._work
        self._combine(current.velocity(dt), work)
        out.data = (self._lagged if lagged is None else lagged) * work
        self._combine(current.stiffness(dt), work)
        weight = current.weight(dt)
        out.data -= weight * self._offset_load
        out.data -= weight * (self._stiffness * work)
        self.loads.add_to(out, boundary, current.loads(n, dt), n * dt, lift)
        for outlet, c in zip(self.outlets, self.flux_vectors):
            out.data -= outlet.load(current, n, dt) * c

    def lagged_right_hand_side(self, out: ngs.BaseVector, boundary: ngs.BaseVector, n: int,
                               work: tuple[ngs.BaseVector, ngs.GridFunction],
                               product: ngs.BaseVector | None = None) -> None:
        """Into ``out`` step n's right-hand side but for its term in vⁿ⁻¹, while vⁿ⁻¹ is being solved for
        (the history holds level n − 2): with uⁿ⁻¹ = ũⁿ⁻¹ + τ vⁿ⁻¹ the term K eⁿ does not see vⁿ⁻¹
        (e_u τ + e_v = 0), only R aⁿ and the outlets' loads do (`add_lagged` adds them). ``work``: a vector and a
        GridFunction on X_h;
        ``product``: R vⁿ⁻² if already formed. The Dirichlet values into ``boundary``."""
        scheme, dt = self.time_scheme, self.dt
        work, explicit = work
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
        self.loads.add_to(out, boundary, scheme.loads(n, dt), n * dt)

    def add_lagged(self, out: ngs.BaseVector, velocity: ngs.BaseVector, n: int,
                   product: ngs.BaseVector | None = None) -> None:
        """out += a R vⁿ⁻¹ − Σ_i s_i c_i once ``velocity`` vⁿ⁻¹ (step n − 1, not yet accepted) is solved, a its
        coefficient in aⁿ (`timeschemes`), s_i the outlets' loads of step n from Qⁿ⁻¹ = c_iᵀvⁿ⁻¹: the terms of step
        n's right-hand side that `lagged_right_hand_side` leaves out; R vⁿ⁻¹ also into ``product`` if given (for
        step n + 1's term in vⁿ⁻¹, BDF2)."""
        newest = self.time_scheme.velocity(self.dt)[1]
        if product is None:
            out.data += newest * (self._lagged * velocity)
        else:
            product.data = self._lagged * velocity
            out.data += newest * product
        for outlet, c, flow in zip(self.outlets, self.flux_vectors, self.outlet_flows(velocity)):
            out.data -= outlet.load(self.time_scheme, n, self.dt, solved=flow) * c

    def _start_solve(self, current, n: int, out: ngs.BaseVector) -> None:
        """Step n of ``current``, whose τ' differs from the run's τ (BDF2's Crank–Nicolson start): its
        matrix A(τ') and operator R' are assembled for this step only and A(τ') x = b is solved by Richardson
        x ← x + ω D A(τ)⁻¹ D (b − A(τ') x) with the run's solver, D scaling the pressure by τ/τ' so that D A(τ') D
        has A(τ)'s constraint. Its eigenvalues against A(τ) lie in [r², 1], r = τ'/τ < 1 (the velocity block
        on the discrete kernel, 1 elsewhere), so ω = 2/(1 + r²) contracts by (1 − r²)/(1 + r²) (0.28 for BDF2).
        The supports' and outlets' terms are positive semi-definite with ratios in [r², r] (γ'/γ of an outlet), so
        the bound holds with them. Each A(τ)⁻¹ is inexact at the auto tolerance: it reduces its right-hand side by ρ
        (its start is zero), which moves the contraction by about ρ, and the iteration's fixed point is A(τ')⁻¹b
        whatever the inner accuracy (a fixed tolerance solves to it; the artery's start at 155 948 unknowns:
        see BENCHMARKS.md, "BDF2's start with inexact inner solves")."""
        spaces, mat, dt, supports = self.spaces, self.coefficients, self.dt, self.data.supports
        tau = current.tau(dt)
        unit = self.pressure_unit
        matrix = compact(forms.step_matrix(spaces, mat, tau, supports, unit=unit).Assemble().mat)
        lagged = compact(forms.lagged_operator(spaces, mat, *current.lagged(dt), supports, unit).Assemble().mat)
        weights = [outlet.weight(current, dt) for outlet in self.outlets]
        self.right_hand_side(current, n, self._rhs, self._boundary, lagged, lift=False)
        free = ngs.Projector(spaces.mixed.FreeDofs(), True)
        out.data = self._boundary + free * self.guess()
        residual, correction = out.CreateVector(), out.CreateVector()
        zero = out.CreateVector()
        zero[:] = 0.0
        pressure = slice(spaces.velocity.ndof, spaces.mixed.ndof)
        scale, ratio = self.tau / tau, (tau / self.tau) ** 2
        omega = 2 / (min(1.0, ratio) + max(1.0, ratio))
        for _ in range(START_MAX_ITERATIONS):
            residual.data = self._rhs - matrix * out
            for c, gamma, flow in zip(self.flux_vectors, weights, self.outlet_flows(out)):
                residual.data -= (gamma * flow) * c
            residual.data = free * residual
            residual.FV().NumPy()[pressure] *= scale
            target = None if self.reduction is None else self.reduction * ngs.Norm(residual)
            self.solver.solve_step(residual, zero, correction, zero, target)
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
        E(U¹ − U⁰) (the Crank–Nicolson start's level n − 1 is U⁰). A tissue support's springs are in it (through K);
        a Windkessel's capacitor, which may give energy back, is not."""
        if self.previous is None or self.n == 0:
            return self._energy(self.state.vec, self.carried.vec)
        if self._extrapolated is None:
            self._extrapolated = (self.state.vec.CreateVector(), self.state.vec.CreateVector())
        x, u = self._extrapolated
        x.data = 2 * self.state.vec - self.previous[0]
        u.data = 2 * self.carried.vec - self.previous[1]
        return 0.5 * (self._energy(self.state.vec, self.carried.vec) + self._energy(x, u))
