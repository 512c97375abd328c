"""The fully discrete scheme (5.1): backward Euler, one saddle-point solve per step,
then the pointwise stress update.

Everything that depends only on the mesh and Δt — the step-1 matrix and its solver,
the mass and stiffness operators, the load vectors of time-separable data — is built
once in `BackwardEuler.__init__`; `step` only applies operators to vectors.

Lean operators: the stress update is linear and exact by (18), so with the displacement
uⁿ_h = I_h u⁰ + Δt Σ_{k≤n} vᵏ (5), σⁿ_h = σ*_h + C ε(uⁿ_h), where σ*_h = σ⁰_h − C ε(I_h u⁰) is zero unless
σ⁰_h is the L² projection (26). The term −Δt ∫_S σⁿ⁻¹:ε(w) of step 1 is −Δt (b* + K uⁿ⁻¹_h), with
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
from .geometry import FLUID, INTERFACE, SOLID, interface_normal
from .manufactured import grad
from .materials import Materials
from .solvers import MAX_ITERATIONS, TOLERANCE, compact, factorise, step_solver
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


#: From this many free unknowns on `march` overlaps each solve with the rest of the previous step in
#: a second thread; below, handing the work over (0.1–0.3 ms a step here) costs more than it saves
#: (benchmarks/scheme_timings.py, paper's experiment: 4 407 unknowns 0.97 ms a step against 0.92
#: sequentially, 17 931: 3.1 against 3.4 ms).
MARCH_THREAD_MIN_DOFS = 10_000


class BackwardEuler:
    """Backward Euler for (10) on V_h × Q_h × S_h with the decoupled stress update (5.1).

    The state is (vⁿ, pⁿ) (``state``) and the displacement uⁿ_h (``displacement``, the velocity part of
    ``carried``); ``stress`` is σⁿ_h = σ*_h + λ div uⁿ_h I + 2μ ε(uⁿ_h), a CoefficientFunction (σ*_h: see the
    module's docstring; a GridFunction on S_h only where σ⁰_h is a projection, else None)."""

    def __init__(self, spaces: Spaces, materials: Materials, data: Data, dt: float,
                 solver: str | None = None, tolerance: float = TOLERANCE,
                 max_iterations: int = MAX_ITERATIONS):
        """``solver``: a name `solvers.step_solver` accepts (None: ``"auto"``); ``tolerance`` and
        ``max_iterations`` are the iterative solver's."""
        if dt <= 0:
            raise ValueError(f"dt: expected a positive time step, got {dt}")
        self.spaces, self.materials, self.data, self.dt = spaces, materials, data, dt
        X, dim = spaces.mixed, spaces.mesh.dim

        step = forms.step_matrix(spaces, materials, dt).Assemble()
        self._matrix = compact(step.mat)
        del step
        self.solver = step_solver(self._matrix, spaces, materials, dt, solver, tolerance, max_iterations)
        self._stiffness = compact(forms.solid_stiffness(spaces, materials).Assemble().mat)
        self._lagged_mass = compact(forms.solid_stiffness(spaces, materials, -dt**2, mass=True).Assemble().mat)
        self._work = self._matrix.CreateColVector()

        self._loads = self._load_vectors()
        self._dirichlet, self._lifts = self._dirichlet_vectors()

        self.state = ngs.GridFunction(X)       # (vⁿ, pⁿ)
        self.carried = ngs.GridFunction(X)     # (uⁿ_h, 0)
        self.velocity, self.pressure = self.state.components
        self.displacement = self.carried.components[0]
        self.stress_offset = ngs.GridFunction(spaces.stress) if data.stress0 is not None else None   # σ*_h
        self.stress = forms.elastic_stress(self.displacement, materials, dim)
        if self.stress_offset is not None:
            self.stress = self.stress_offset + self.stress
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
        self.time, self.n = 0.0, 0

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
        self._offset_energy = ngs.Integrate(self._compliance(offset, offset), mesh, definedon=solid)

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
        """One step of (5.1): (vⁿ, pⁿ) from the saddle-point system, then the stress update
        σⁿ = σⁿ⁻¹ + Δt (λ div vⁿ I + 2μ ε(vⁿ)), exact by (18), as uⁿ_h = uⁿ⁻¹_h + Δt vⁿ."""
        time = (self.n + 1) * self.dt  # no accumulated round-off in tₙ = nΔt
        self.right_hand_side(time)
        self.solve()
        self.update_stress()
        self.time, self.n = time, self.n + 1

    def march(self, steps: int, observe: Callable[[BackwardEuler], None] | None = None) -> None:
        """``steps`` steps of (5.1), calling ``observe(self)`` after each one with the scheme at that step.

        From `MARCH_THREAD_MIN_DOFS` free unknowns on, a second thread finishes step n while this one
        solves step n + 1: the stress update uⁿ_h = uⁿ⁻¹_h + Δt vⁿ, ``observe`` (one call at a time
        and in order; the last in this thread) and the part of the next right-hand side without vⁿ⁺¹
        (`_lagged_data`).
        Between two solves only the product (M − Δt² K) vⁿ⁺¹ is left. ``observe`` must not step
        the scheme. The results equal `step` repeated up to round-off (7e-14 relative after 100 steps of the
        paper's experiment, level 4). Under NGSolve's TaskManager the two threads compete for its workers:
        `step` is faster there (100 steps at 17 931 unknowns: 0.33 s against 0.43 s)."""
        if steps <= 0:
            return
        if not self.solver.overlap or self.spaces.free_dofs() < MARCH_THREAD_MIN_DOFS:
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

    def _accept(self, solution: ngs.BaseVector, n: int, observe) -> None:
        """Make step n the scheme's state: (vⁿ, pⁿ), uⁿ_h, tₙ; then ``observe``."""
        self.state.vec.data = solution
        self.update_stress()
        self.time, self.n = n * self.dt, n
        if observe is not None:
            observe(self)

    def _lagged_data(self, out: ngs.BaseVector, boundary: ngs.BaseVector, time: float) -> None:
        """Into ``out`` the right-hand side at ``time`` but for its term (M − Δt² K) v of the step
        before: −Δt (b* + K u_h) with the current u_h, the loads and the lifts; the Dirichlet values into
        ``boundary``."""
        out.data = -self.dt * self._offset_load
        out.data -= self.dt * (self._stiffness * self.carried.vec)
        self._add_data(out, boundary, time)

    def right_hand_side(self, time: float) -> None:
        """Step 1's right-hand side, Δt f(tₙ) + ρ vⁿ⁻¹ − Δt σⁿ⁻¹:ε(·), minus the lift of the
        Dirichlet values vⁿ|∂Ω; the lift itself is kept in the boundary vector. The scheme keeps
        M − Δt² K and K (not M): ρ vⁿ⁻¹ − Δt(b* + K uⁿ⁻¹_h) = (M − Δt² K) vⁿ⁻¹ − Δt(b* + K uⁿ⁻²_h)."""
        self._work.data = self.carried.vec - self.dt * self.state.vec   # uⁿ⁻²_h (velocity part)
        self._rhs.data = self._lagged_mass * self.state.vec
        self._rhs.data -= self.dt * self._offset_load
        self._rhs.data -= self.dt * (self._stiffness * self._work)
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
        """Step 2 of (5.1), exact by (18), as the displacement's update (5): uⁿ_h = uⁿ⁻¹_h + Δt vⁿ."""
        self.displacement.vec.data += self.dt * self.velocity.vec

    def energy(self) -> float:
        """½∫ρ|vⁿ|² + ½∫_S Aσⁿ_h:σⁿ_h; non-increasing when f = 0 and the boundary is at rest. With
        σⁿ_h = σ*_h + Cε(uⁿ_h): ∫_S Aσⁿ_h:σⁿ_h = ∫_S Aσ*_h:σ*_h + 2 b*·uⁿ_h + uⁿ_h·K uⁿ_h."""
        x, u = self.state.vec, self.carried.vec
        elastic = self._offset_energy + 2 * InnerProduct(self._offset_load, u) + InnerProduct(u, self._stiffness * u)
        kinetic = InnerProduct(x, self._lagged_mass * x) + self.dt**2 * InnerProduct(x, self._stiffness * x)
        return 0.5 * (kinetic + elastic)
