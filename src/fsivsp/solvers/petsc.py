"""The PETSc backend for step 1 of (5.1): a Krylov method with a PCFIELDSPLIT Schur-complement preconditioner,
serial or over all MPI ranks.

The step matrix on the free dofs is [[A, C^T], [C, 0]], C = −ΔtB, A = ρM + 2νΔt K_F + Δt²(2μ K_S + λ D_S)
(`forms.step_matrix`). PETSc sees it as one AIJ matrix (MPIAIJ under mpirun, its rows split evenly over the
ranks in `petsc_layout`'s order) with two named fields:

- ``velocity``: A⁻¹ by one BoomerAMG V-cycle on the velocity dofs ordered node by node (block size d), the rigid
  motions attached as near-nullspace (the kernel of ε, in the fluid and the solid alike);
- ``pressure``: the Schur complement S = −C A⁻¹ Cᵀ by the corrected least-squares commutator of
  `petsc_schur`, S⁻¹ ≈ F⁻¹ (Yᵀ A Y) F⁻¹ with Y = diag(A)⁻¹ Cᵀ and F = C Y (F⁻¹ by two BoomerAMG
  cycles), built with PETSc's sparse products; or Cahouet–Chabard, S⁻¹ ≈ F_ρ⁻¹ + 2ν/Δt diag(M_p)⁻¹
  (``schur_approximation = "cahouet-chabard"``), or PETSc's own (``"petsc"``).

The Krylov method is FGMRES on the unpreconditioned residual, stopped at ``tol`` times ‖b‖. Under mpirun
``solver = "direct"`` is MUMPS's LU (`MUMPS`). Every choice is a PETSc option under the prefix ``fsivsp_``
(`DEFAULTS`), overridden by the case file's ``[solver.petsc]`` table or ``--petsc-options``, e.g.
``-fsivsp_ksp_monitor`` or ``-fsivsp_fieldsplit_velocity_pc_type gamg``.
"""
from __future__ import annotations

import time
from collections.abc import Mapping

import ngsolve as ngs
import numpy as np

from ..fem.spaces import Spaces
from ..model.materials import Materials
from ..runtime import parallel
from ..runtime.threads import idle
from .base import AUTO, TOLERANCE, NotConverged
from .petsc_basis import takes_lagrange
from .petsc_init import entered_options, option_names, petsc, register, unregister
from .petsc_joint import joint_pressure_block
from .petsc_layout import aij, from_summands, layout
from .petsc_mass import DEFAULTS_SSOR, MASS_DOMINATED, ratio_for, sets_velocity
from .petsc_pmg import COARSE, SMOOTH, velocity_block
from .petsc_schur import pressure_block
from .sparse import to_scipy_csr

PREFIX = "fsivsp_"

#: The direct solve over MPI ranks (``solver = "direct"`` under mpirun): MUMPS's LU of the whole step matrix.
MUMPS: dict[str, str] = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}

#: The measured defaults (docs/solvers.md, "PETSc"). Keys without the prefix; values as PETSc reads them.
DEFAULTS: dict[str, str] = {
    "ksp_type": "fgmres",
    "ksp_gmres_restart": "100",
    "ksp_pc_side": "right",
    "pc_type": "fieldsplit",
    "pc_fieldsplit_type": "schur",
    "pc_fieldsplit_schur_fact_type": "upper",
    "pc_fieldsplit_schur_precondition": "selfp",
    "velocity_preconditioner": "boomeramg",
    "fieldsplit_velocity_ksp_type": "preonly",
    "fieldsplit_velocity_pc_type": "hypre",
    "fieldsplit_pressure_ksp_type": "preonly",
    "schur_approximation": "lsc",
    "schur_higher_weight": "1",
    "schur_laplacian_basis": "lagrange",
    "schur_laplacian_pc_type": "hypre",
    "schur_laplacian_pc_hypre_boomeramg_max_iter": "2",
}

#: BoomerAMG on the velocity in 3D: the settings for 3D elasticity-like systems (strong threshold 0.5, HMIS
#: coarsening, ext+i interpolation with at most 4 entries per row, aggressive coarsening on the first level):
#: on level 3 of the 3D fluid ball 14 iterations at 17 ms per V-cycle against 10 at 64 ms with hypre's
#: defaults. In 2D the defaults are better (the paper's levels 2-4: 13, 16, 21 iterations against 24, 30, 37).
#: The smoother stays hypre's hybrid symmetric Gauss–Seidel: its l1-scaled variant, as fast serially (the 3D tube
#: at maxh 0.1: 31.3 iterations either way), broke down over ranks (2 ranks: 159 against 34 iterations).
#: The pressure Laplacian F takes the same coarsening (not the smoother): on the 3D tube at maxh 0.1 (57 645
#: unknowns) its operator complexity with hypre's defaults is 4.1 (F = C diag(A)⁻¹ Cᵀ has 55 entries a row) and
#: the pressure block took 1.29 of 2.03 s of the solves, 0.41 s with these, in the same 31.3 iterations; the 3D
#: ball's level 3: 28.5 iterations either way.
DEFAULTS_3D: dict[str, str] = {
    **{f"{block}_pc_hypre_boomeramg_{key}": value for block in ("fieldsplit_velocity", "schur_laplacian")
       for key, value in (("strong_threshold", "0.5"), ("coarsen_type", "HMIS"), ("interp_type", "ext+i"),
                          ("P_max", "4"), ("agg_nl", "1"))},
}


#: hypre's options for elasticity on the velocity in 3D (MFEM's set): nodal coarsening on the d components of a node,
#: the rigid motions (the near-nullspace) in the interpolation, no aggressive coarsening. Issue 33's prototype, the 3D
#: fluid ball at Δt = 0.1, levels 1–3, tolerance 1e-12: 23 → 24 → 34 iterations become 21 → 16 → 17 (an exact velocity
#: solve: 20 → 14 → 17). In 2D they were slightly worse than hypre's defaults, which 2D keeps.
ELASTICITY_3D: dict[str, str] = {
    f"fieldsplit_velocity_pc_hypre_boomeramg_{key}": value
    for key, value in (("nodal_coarsen", "4"), ("vec_interp_variant", "2"), ("vec_interp_qmax", "4"),
                       ("vec_interp_smooth", "true"), ("interp_refine", "1"), ("strong_threshold", "0.5"),
                       ("agg_nl", "0"))}

#: With a solid pressure (`fem.spaces`): the joint Cahouet–Chabard pressure block over (p, ŝ) (`petsc_joint`), its
#: weighted mass inverted by three Chebyshev–Jacobi steps; PETSc's Schur matrix is the pressure block itself (a11),
#: not the unused sparse product of selfp.
DEFAULTS_SOLID_PRESSURE: dict[str, str] = {
    "schur_approximation": "joint-cahouet-chabard",
    "pc_fieldsplit_schur_precondition": "a11",
    "schur_mass_ksp_type": "chebyshev",
    "schur_mass_ksp_max_it": "3",
    "schur_mass_ksp_norm_type": "none",
    "schur_mass_ksp_chebyshev_esteig": "0.8,0,0,1.1",
    "schur_mass_ksp_chebyshev_esteig_steps": "20",
    "schur_mass_pc_type": "jacobi",
}

#: With a solid pressure in 3D: the joint least-squares commutator (`petsc_joint`). The joint Cahouet–Chabard block's
#: lower spectral bound against the exact Schur complement falls with h in the 3D fluid (the solid ball, MINI,
#: λ/μ = 10⁴, Δt = 0.02, levels 0–2: 0.41, 0.25, 0.14, the low modes 97 % in the fluid; with exact velocity and
#: Laplacian solves 22 → 26 iterations on levels 1–2), the commutator's stays at 0.44–0.58 (condition 4.2, 3.3, 3.3).
#: Iterations, tolerance 1e-12: MINI 17.3, 22.0, 27.3 (32.3 on level 3) become 17.3, 17.3, 17.7; Δt = 0.1 31.7 → 34.7
#: become 19.0 → 20.0; the fluid in a solid 20.7 → 27.0 become 20.7 → 19.3; Taylor–Hood 1 24.3 → 24.7 become
#: 19.3 → 20.3, Taylor–Hood 2 33.0 → 37.0 become 34.7 → 31.3. In 2D the commutator grows where the solid is
#: stiffness-dominated (the paper's case, MINI, Δt = 0.1, levels 1–3: 17, 20, 32 against 21, 24, 27): 2D keeps
#: Cahouet–Chabard.
DEFAULTS_SOLID_PRESSURE_3D: dict[str, str] = {"schur_approximation": "joint-lsc"}

#: The joint Laplacian of a pressure of degree k ≥ 2 with a solid pressure: four BoomerAMG cycles (the prototype's
#: Taylor–Hood k = 2 rows).
DEFAULTS_SOLID_PRESSURE_HIGHER: dict[str, str] = {"schur_laplacian_pc_hypre_boomeramg_max_iter": "4"}


#: A pressure of degree k ≥ 2 (Taylor–Hood): three smoothing sweeps on every level of F's V-cycles. Its
#: hierarchical basis makes F a poor M-matrix for BoomerAMG: the 3D solid ball, Taylor–Hood k = 2, levels 0–1:
#: 168, 185 iterations with one sweep, 54, 67 with three (12, 13 with F and the velocity block factorised).
DEFAULTS_HIGHER_PRESSURE: dict[str, str] = {"schur_laplacian_pc_hypre_boomeramg_grid_sweeps_all": "3"}


#: Taylor–Hood k ≥ 2 in 2D with F in the hierarchical basis (``schur_laplacian_basis = "hierarchical"``; `LAGRANGE_2D`
#: in the Lagrange basis): the commutator's weights D = diag(A) times 4 on the velocity's higher dofs
#: (`petsc_schur.commutator`). With diag(A) the commutator overweights smooth pressures by a factor growing like h⁻²
#: (κ(P⁻¹S), velocity block exact, the paper's case at Δt = 0.1, levels 1–3: 2.8, 7.8, 27; ×4: 2.3, 2.7, 5.5, ×16: 5.0,
#: 4.8, 5.2, but then F is hard for BoomerAMG in this basis: 54–69 iterations). The paper's case, levels 1–4, Δt = 0.1:
#: 13.3, 16.3, 22.3, 31.7 → 19.3, 19.7, 19.7, 22.7 (BENCHMARKS.md, "Taylor–Hood k = 2 in 2D"). In 3D it costs
#: (solid_in_fluid_3d at Δt = 0.02, levels 0–1: 26.3, 27.0 → 31.3, 34.3) and 3D keeps 1.
DEFAULTS_HIGHER_2D: dict[str, str] = {"schur_higher_weight": "4"}

#: A pressure of degree 2 (Taylor–Hood k = 2) with F's AMG in the Lagrange basis (`petsc_basis`, the default): in 2D
#: the commutator's weights D = diag(A) × 6 on the velocity's higher dofs. F's BoomerAMG now holds the edge modes that
#: a larger weight leaves to F (in the hierarchical basis ×16 took 54–69 iterations): the paper's case, levels 0–4,
#: Δt = 0.1, 10⁻², 10⁻³, 10⁻⁴: 14.3, 15.3, 15.7, 17.3, 18.3; 14.0, 13.7, 14.0, 15.7, 16.0; 10.0, 10.7, 10.7, 9.3, 8.3;
#: 5.0, 4.7, 5.3, 5.0, 5.7, level 4 in 0.78–1.03× the time of the hierarchical basis (× 4: 14.3, 14.3, 16.3, 19.3 on
#: levels 1–4 at Δt = 0.1; × 8: 14.3, 17.3, 18.0 on levels 2–4 at 10⁻², +21 %; BENCHMARKS.md, "Taylor–Hood k = 2: F in
#: the Lagrange basis"). At most 4 interpolation weights a row on F: in this basis hypre's 2D defaults made F's
#: operator complexity 5.4 on level 4 (3.9 with it, the same iterations, 0.92× the time).
LAGRANGE_2D: dict[str, str] = {"schur_higher_weight": "6", "schur_laplacian_pc_hypre_boomeramg_P_max": "4"}

#: A pressure of degree 2 in 3D with F in the Lagrange basis: one smoothing sweep and two cycles on F (F is no longer
#: the hard part: `DEFAULTS_HIGHER_PRESSURE`'s three sweeps and `PMG_HIGHER`'s four cycles cost time and no
#: iterations), four SSOR sweeps in the velocity's p-multigrid. The solid ball at Δt = 0.02, levels 0–2: 26.3, 27.0,
#: 27.0 iterations (75.2 s on level 2) in the hierarchical basis; 19.0, 22.0, 23.7 (67.5 s) in the Lagrange basis
#: with the old cycles; 20.3, 20.7, 21.0 (46.1 s) with these.
LAGRANGE_3D: dict[str, str] = {"schur_laplacian_pc_hypre_boomeramg_grid_sweeps_all": "1",
                               "schur_laplacian_pc_hypre_boomeramg_max_iter": "2", f"{SMOOTH}ksp_max_it": "4"}

#: A pressure of degree 2 with F in the Lagrange basis and a solid pressure: one smoothing sweep on the joint Laplacian
#: (in 3D `LAGRANGE_3D` already). The paper's case at λ/μ = 10⁴, levels 1–3, Δt = 10⁻² and 0.1: 25.0, 24.0, 24.3 and
#: 32.0, 31.3, 33.0 iterations, level 3 in 19.5 and 27.7 s; with three sweeps the same iterations in 33.8 and 45.8 s;
#: in the hierarchical basis 24.0, 23.0, 25.0 and 32.0, 35.0, 38.3 in 25.3 and 33.8 s.
LAGRANGE_SOLID_PRESSURE: dict[str, str] = {"schur_laplacian_pc_hypre_boomeramg_grid_sweeps_all": "1"}


#: hypre's elasticity options without a block's prefix (`ELASTICITY_3D`'s values).
_ELASTICITY = {key.removeprefix("fieldsplit_velocity_"): value for key, value in ELASTICITY_3D.items()}

#: The velocity block by the two-level p-multigrid of `petsc_pmg` (Taylor–Hood's default, `default_velocity`): two
#: symmetric SOR sweeps on all velocity dofs, one BoomerAMG V-cycle on the vertex (P1) dofs, in 3D with hypre's
#: elasticity options over the 3D settings of `DEFAULTS_3D` (as on the velocity), in 2D with hypre's own: there the
#: elasticity options made the paper's case with Taylor–Hood k = 1 at Δt = 0.1 take 12.0, 14.3, 16.0, 23.3 iterations
#: on levels 1–4 against 12.3, 13.3, 15.3, 17.3 (13.5 against 7.5 s on level 4; at 10⁻² 14.7 on level 4 either way,
#: 8.8 against 6.3 s; BENCHMARKS.md, "Taylor–Hood in 2D").
DEFAULTS_PMG: dict[str, str] = {
    "velocity_preconditioner": "p-multigrid",
    "fieldsplit_velocity_pc_type": "none",   # replaced by the two-level cycle after the fieldsplit's set-up
    f"{SMOOTH}ksp_type": "richardson",
    f"{SMOOTH}ksp_max_it": "2",
    f"{SMOOTH}ksp_norm_type": "none",
    f"{SMOOTH}pc_type": "sor",
    f"{COARSE}pc_type": "hypre",
}


#: With the p-multigrid and Taylor–Hood k ≥ 2 (velocity P_{k+1}, pressure P_k): three SSOR sweeps a smoothing and
#: four BoomerAMG cycles on the pressure Laplacian. The 3D solid ball, Δt = 0.02, levels 0–1, tolerance 1e-12:
#: λ/μ = 2, no solid pressure: 42.0 → 43.7 iterations with two sweeps and two cycles, 27.0 → 28.7 with four cycles,
#: 26.0 → 27.0 with three sweeps too; λ/μ = 10⁴ with a solid pressure (four cycles already): 35.7 → 40.7 with two
#: sweeps, 33.0 → 37.0 with three (30.0 → 33.7 with the velocity block factorised).
PMG_HIGHER: dict[str, str] = {"schur_laplacian_pc_hypre_boomeramg_max_iter": "4", f"{SMOOTH}ksp_max_it": "3"}


#: MINI's velocity block in 3D: its cell bubbles condensed (`petsc_pmg.Condensed`: A_bb⁻¹ exact, cell by cell) and one
#: BoomerAMG cycle on the vertex Schur complement S with `DEFAULTS_3D`'s settings, nodal coarsening and no aggressive
#: coarsening. BoomerAMG on the whole block coarsens the bubbles badly: on level 3 of the 3D fluid ball (65 130
#: unknowns, Δt = 0.02) the first coarse level keeps 44 685 of 63 381 rows at 384 entries a row with `ELASTICITY_3D`
#: (operator complexity 13.0; 2.8 with aggressive coarsening, at 8.2 iterations a step), S's hierarchy 2.7; the step
#: takes 0.26 s against 1.23 s at 5.0 iterations either way. With a solid pressure (MINI's bubbles on the solid cells
#: too) it is not the default: the solid ball at λ/μ = 10⁴, the auto tolerance, 3 steps, levels 0–3: 10.7, 10.0, 12.0,
#: 18.0 iterations against BoomerAMG's 10.7, 10.3, 11.3, 17.0 (+20 % from level 1 to 2 against +10 %), though level
#: 3's (313 440 unknowns) three steps take 7.9 s against 20.1 s. Interpolation weights below 0.2 of a row's largest are
#: dropped (``truncfactor``): on the ball's level 4 (535 830 unknowns) S's coarse levels densified to operator
#: complexity 3.3 (the first coarse level 124 entries a row against the fine level's 44), 3.0 with it, in the same
#: iterations (10 steps: 23, 21, 8, 7, …) and 0.90× the time a step; 0.3 costs an iteration on the first step, 0.5
#: two a step. The cycle smooths by one forward hybrid Gauss–Seidel sweep down and one forward sweep up (PETSc's
#: default is a symmetric sweep each way, twice the work): on level 4 the cycle costs 5.3 step-matrix products
#: (PETSc's, one thread) against 10.3; 10 steps took 27, 24, 10, 9, 9, 7, 7, 6, 6, 6 iterations against 23, 21, 9,
#: 7, 7, 6, 6, 5, 6, 6, at 0.71× the time (forward down and backward up: 0.79×; V(1,0): 38, 35, 16, …). The cycle is
#: not symmetric; the outer FGMRES does not need it to be. The commutator's Laplacian F takes `STIFF_F_CYCLES` where
#: the stiffness dominates the block (`petsc_mass.MASS_DOMINATED`).
DEFAULTS_CONDENSED: dict[str, str] = {
    "velocity_preconditioner": "condensed",
    "fieldsplit_velocity_pc_type": "none",   # replaced by the condensed block after the fieldsplit's set-up
    f"{COARSE}pc_type": "hypre",
    **{f"{COARSE}pc_hypre_boomeramg_{key}": value
       for key, value in (("strong_threshold", "0.5"), ("coarsen_type", "HMIS"), ("interp_type", "ext+i"),
                          ("P_max", "4"), ("agg_nl", "0"), ("nodal_coarsen", "4"),
                          ("truncfactor", "0.2"), ("relax_type_down", "SOR/Jacobi"),
                          ("relax_type_up", "SOR/Jacobi"))},
}


#: With the condensed block where the stiffness dominates (q > `petsc_mass.MASS_DOMINATED`): 4 BoomerAMG cycles on the
#: commutator's Laplacian F (2 with the other velocity preconditioners, `DEFAULTS`). S's cycle, not F's, is then most
#: of an iteration, and the robustness table's 3D rows at Δt = 0.1, 10⁻² take 1.0–6.6 fewer iterations on level 3 at
#: 0.90–0.97× the time (6 cycles: at most 1.3 fewer); the ball's level 4, 10 steps: 22, 20, 9, 8, 8, 7, 7, 6, 6, 5
#: at 0.89× the time. Where the mass dominates F's cycles are as dear as S's and the commutator needs fewer: the 3D
#: tube at 249 599 unknowns (q = 4.1, 10 steps, the auto tolerance) takes 4.7 iterations a step with 2 cycles or 4,
#: 0.375 against 0.464 s a step.
STIFF_F_CYCLES: dict[str, str] = {"schur_laplacian_pc_hypre_boomeramg_max_iter": "4"}


def default_velocity(spaces: Spaces, nodal: bool = True) -> str:
    """The velocity block's preconditioner by default (where it is BoomerAMG, SSOR if the mass dominates:
    `petsc_mass.MASS_DOMINATED`): MINI's bubbles condensed in 3D without a solid pressure (``nodal``: PETSc's velocity
    rows node by node, `petsc_layout`, so that a cell's d bubble rows are adjacent); for Taylor–Hood the p-multigrid
    (in 2D too since issue 33's ninth session: BoomerAMG on the hierarchical P2 basis took 20.7, 29.3, 52.3, 166.3
    iterations on the paper's levels 1–4 at Δt = 0.1); else BoomerAMG. MINI in 2D or with a solid pressure keeps
    BoomerAMG (the paper's discretisation: its measured tables unchanged; with a solid pressure the condensed block is
    faster but grows more, `DEFAULTS_CONDENSED`)."""
    three = spaces.mesh.dim == 3
    if spaces.family == "mini" and three and nodal and spaces.solid_pressure is None:
        return "condensed"
    if spaces.family == "taylor_hood":
        return "p-multigrid"
    return "boomeramg"


def velocity_options(spaces: Spaces, name: str, mass_dominated: bool = False) -> dict[str, str]:
    """The velocity block's options over `DEFAULTS` for the preconditioner ``name`` (`spec.VELOCITY_PRECONDITIONERS`):
    BoomerAMG on V_h (in 3D `DEFAULTS_3D` and `ELASTICITY_3D`), `DEFAULTS_SSOR`, `DEFAULTS_CONDENSED` (with
    `STIFF_F_CYCLES` unless the block's mass dominates, ``mass_dominated``: `petsc_mass.MASS_DOMINATED`) or the
    p-multigrid of `DEFAULTS_PMG`."""
    three = spaces.mesh.dim == 3
    options = {"velocity_preconditioner": name, **(DEFAULTS_3D if three else {}), **(ELASTICITY_3D if three else {})}
    if name == "ssor":
        options.update(DEFAULTS_SSOR)
    elif name == "condensed":
        options.update({**DEFAULTS_CONDENSED, **({} if mass_dominated else STIFF_F_CYCLES)})
    elif name == "p-multigrid":
        coarse = ({key.removeprefix("fieldsplit_velocity_"): value for key, value in DEFAULTS_3D.items()
                   if key.startswith("fieldsplit_velocity_")} | _ELASTICITY) if three else {}
        options.update({**DEFAULTS_PMG, **{COARSE + key: value for key, value in coarse.items()}})
        if spaces.order >= 2:
            options.update(PMG_HIGHER)
    return options


def rigid_motions(points: np.ndarray) -> np.ndarray:
    """The rigid motions at ``points`` (n × d, relative to a centre) as columns of an (n·d × m) array, node by node
    (x₁, y₁[, z₁], x₂, …): d translations and d(d−1)/2 rotations."""
    n, d = points.shape
    modes = [np.zeros((n, d)) for _ in range(d + d * (d - 1) // 2)]
    for j in range(d):
        modes[j][:, j] = 1.0
    for k, (a, b) in enumerate([(0, 1)] if d == 2 else [(0, 1), (1, 2), (2, 0)]):
        modes[d + k][:, a], modes[d + k][:, b] = -points[:, b], points[:, a]
    return np.column_stack([m.ravel() for m in modes])


class PETScSolver:
    """Step 1 by PETSc's KSP with the fieldsplit preconditioner of the module's docstring, serial or over the
    MPI ranks of a distributed mesh (the rows in `petsc_layout`'s order, split evenly over the ranks).

    ``solve_step(rhs, boundary, out, guess)`` sets ``out = boundary + A_ff⁻¹ rhs`` from the free part of
    ``guess``; raises `NotConverged` when PETSc's KSP stops without reaching ``tol`` ‖b‖.
    """

    method = "petsc"

    def __init__(self, matrix: ngs.BaseMatrix, spaces: Spaces, materials: Materials, dt: float, tol: float | str,
                 maxiter: int, options: Mapping[str, object] | None = None):
        if tol != AUTO and not 0 < tol < 1:
            raise ValueError(f"tolerance: expected auto or a number in (0, 1), got {tol!r}")
        PETSc = petsc()
        start = time.perf_counter()
        self.PETSc, self.maxiter = PETSc, maxiter
        self.auto = tol == AUTO   # then a solve from a start stops at its target too (`solve_step`)
        self.tol = TOLERANCE if self.auto else tol
        self.distributed = isinstance(matrix, ngs.la.ParallelMatrix)
        self.overlap = not self.distributed  # its products and reductions communicate: one MPI call at a time
        self.comm = PETSc.COMM_WORLD if self.distributed else PETSc.COMM_SELF
        local = to_scipy_csr(matrix.local_mat if self.distributed else matrix)
        self.layout = L = layout(spaces, local)
        self._numbers = L.numbers.astype(PETSc.IntType)
        self._field = L.field.astype(PETSc.IntType)
        self.A = self.petsc_matrix(local[L.local][:, L.local].tocsr())
        first, middle, stop = L.rows[0], L.velocity_rows[1], L.rows[1]
        self.fields = (PETSc.IS().createStride(middle - first, first, 1, comm=self.comm),
                       PETSc.IS().createStride(stop - middle, middle, 1, comm=self.comm))
        self.fields[0].setBlockSize(L.blocksize)
        self._b, self._x = self.A.createVecs()
        self._near_nullspace = self._rigid_motions(spaces)
        self.fields[0].compose("nearnullspace", self._near_nullspace)

        solid = spaces.solid_pressure is not None
        given = option_names(options or {}, PREFIX)
        velocity = str(given.get("velocity_preconditioner", default_velocity(spaces, L.blocksize == spaces.mesh.dim)))
        self.stiffness_ratio = ratio_for(self, spaces, materials, velocity)
        mass = self.stiffness_ratio is not None and self.stiffness_ratio <= MASS_DOMINATED
        if mass and velocity == "boomeramg" and not sets_velocity(given):
            velocity = "ssor"
        two, lagrange = spaces.mesh.dim == 2, takes_lagrange(spaces, {**DEFAULTS, **given})
        defaults = {**DEFAULTS,
                    **velocity_options(spaces, velocity, mass),
                    **(DEFAULTS_HIGHER_PRESSURE if spaces.order >= 2 else {}),
                    **(DEFAULTS_HIGHER_2D if spaces.order >= 2 and two else {}),
                    **(DEFAULTS_SOLID_PRESSURE if solid else {}),
                    **(DEFAULTS_SOLID_PRESSURE_3D if solid and not two else {}),
                    **(DEFAULTS_SOLID_PRESSURE_HIGHER if solid and spaces.order >= 2 else {}),
                    **((LAGRANGE_2D if two else LAGRANGE_3D) if lagrange else {}),
                    **(LAGRANGE_SOLID_PRESSURE if lagrange and solid else {})}
        with entered_options(PETSc, PREFIX, defaults, options or {}) as self.options:
            self.ksp = PETSc.KSP().create(comm=self.comm)
            self.ksp.setOptionsPrefix(PREFIX)
            self.ksp.setOperators(self.A)
            pc = self.ksp.getPC()
            pc.setType("fieldsplit")
            pc.setFieldSplitIS(("velocity", self.fields[0]), ("pressure", self.fields[1]))
            self.ksp.setFromOptions()
            self.ksp.setTolerances(rtol=self.tol, atol=0.0, max_it=maxiter)  # the case's tolerance over ksp_rtol
            self.ksp.setInitialGuessNonzero(self.ksp.getType() != "preonly")  # the previous step (direct: none)
            self.ksp.setUp()  # creates the fieldsplit's sub-KSPs, whose pressure PC is set below
            if pc.getType() == "fieldsplit":
                if (self.options.get("pc_fieldsplit_type") == "schur"
                        and self.options["schur_approximation"] != "petsc"):
                    block = joint_pressure_block if self.options["schur_approximation"].startswith("joint") \
                        else pressure_block
                    self._schur = block(self, spaces, materials, dt)
                if self.options.get("velocity_preconditioner") in ("p-multigrid", "condensed"):
                    self._velocity = velocity_block(self, spaces)
                self.ksp.setUp()
                for block in pc.getFieldSplitSubKSP():  # else PETSc sets up the AMG at the first solve
                    block.setUp()
        self._local = PETSc.Vec().createSeq(len(L.local), comm=PETSc.COMM_SELF)
        self._scatter = PETSc.Scatter().create(self._x, PETSc.IS().createGeneral(self._numbers, comm=PETSc.COMM_SELF),
                                               self._local, None)
        register(self)
        self.iterations: list[int] = []
        self.residual = float("nan")
        self.factor_seconds = time.perf_counter() - start
        self.matvec_seconds = self._matvec_seconds()

    def _matvec_seconds(self, repeats: int = 3) -> float:
        """One product with the step matrix (the fastest of ``repeats``): the unit of a step's cost."""
        self._x.set(1.0)
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            self.A.mult(self._x, self._b)
            times.append(time.perf_counter() - start)
        return min(times)

    def petsc_matrix(self, local):
        """The step matrix on the free dofs as a PETSc AIJ matrix from ``local``, this rank's matrix on its free
        dofs in PETSc's order (scipy CSR): serially itself; distributed a summand of the global matrix."""
        L = self.layout
        if not self.distributed:
            return aij(self.PETSc, local, self.PETSc.COMM_SELF)
        return from_summands(self.PETSc, local, self._numbers, L.rows[1] - L.rows[0], L.size)

    def load_values(self, values: np.ndarray, target, summands: bool) -> None:
        """``values`` of X_h's local vector into the PETSc vector ``target`` (PETSc's order): every rank's added
        where the values are ``summands`` of a distributed vector, else the masters' inserted."""
        L, mode = self.layout, self.PETSc.InsertMode
        values = values[L.local]
        target.set(0.0)
        if summands:
            target.setValues(self._numbers, values, addv=mode.ADD_VALUES)
        else:
            target.setValues(self._numbers[L.master], values[L.master], addv=mode.INSERT_VALUES)
        target.assemble()

    def _load_vector(self, vector: ngs.BaseVector, target) -> None:
        summands = getattr(vector, "GetParallelStatus", lambda: None)() == ngs.la.PARALLEL_STATUS.DISTRIBUTED
        self.load_values(vector.FV().NumPy(), target, summands)

    def field_vector(self, values: np.ndarray):
        """A vector on the velocity field (its sub-matrix's layout) from the velocity master dofs' ``values``."""
        L = self.layout
        vector = self.PETSc.Vec().createMPI((L.nvel_rows, L.nvel), bsize=L.blocksize, comm=self.comm)
        vector.setValues(self._field, values)
        vector.assemble()
        return vector

    def _rigid_motions(self, spaces: Spaces):
        """The near-nullspace of the velocity field: the rigid motions' vertex values (the hierarchical basis's
        higher dofs of a linear field vanish) about the centroid of the vertices, orthonormalised."""
        L, mesh, V = self.layout, spaces.mesh, spaces.velocity
        d, scalar = mesh.dim, V.ndof // mesh.dim
        component, node = np.divmod(L.velocity_masters, scalar)
        vertex = node < mesh.nv
        points = np.array([v.point for v in mesh.vertices]).reshape(-1, d)[node[vertex]]
        sums = parallel.total(np.append(points[component[vertex] == 0].sum(axis=0), np.sum(component[vertex] == 0)))
        modes = rigid_motions(points - sums[:d] / max(sums[d], 1.0)).reshape(-1, d, d * (d + 1) // 2)
        values = np.zeros((len(node), modes.shape[2]))
        values[vertex] = modes[np.arange(vertex.sum()), component[vertex]]
        vectors = []
        for column in values.T:
            vector = self.field_vector(column)
            for other in vectors:  # modified Gram–Schmidt
                vector.axpy(-vector.dot(other), other)
            vector.normalize()
            vectors.append(vector)
        self.keep = list(vectors)
        self.rigid_motion_vectors = vectors
        return self.PETSc.NullSpace().create(vectors=vectors, comm=self.comm)

    def solve_step(self, rhs: ngs.BaseVector, boundary: ngs.BaseVector, out: ngs.BaseVector,
                   guess: ngs.BaseVector | None = None, target: float | None = None) -> None:
        """out = boundary + A_ff⁻¹ rhs (``guess`` may be ``out`` itself; ``target``: `_stopping`)."""
        self._load_vector(rhs, self._b)
        if guess is None:
            self._x.set(0.0)
        else:
            self._load_vector(guess, self._x)
        norm = self._b.norm()
        target = target if self.auto else None   # a fixed tolerance is the tolerance alone
        self._stopping(norm, target)
        with idle():   # PETSc solves on this thread alone
            self.ksp.solve(self._b, self._x)
        self.iterations.append(self.ksp.getIterationNumber())
        self.residual = self.ksp.getResidualNorm() / norm if norm > 0 else 0.0
        if self.ksp.getConvergedReason() < 0:
            rule = f"{self.tol:g}" if target is None else f"auto ({self.tol:g} or the residual {target:.2e})"
            raise NotConverged(f"petsc: {self.ksp.getType()} did not reach the tolerance {rule} in "
                               f"{self.iterations[-1]} iterations (relative residual {self.residual:.2e}, "
                               f"reason {self.ksp.getConvergedReason()})")
        self._scatter.scatter(self._x, self._local, addv=self.PETSc.InsertMode.INSERT_VALUES)
        out.data = boundary
        if self.distributed:
            out.Cumulate()
        out.FV().NumPy()[self.layout.local] += self._local.getArray()

    def _stopping(self, norm: float, target: float | None) -> None:
        """The solve's stopping rule: ‖r‖ ≤ tol ‖b‖ (``norm`` = ‖b‖); with a ``target`` (the auto tolerance's,
        `base.auto_target`, the scheme's) also ‖r‖ ≤ target, whichever comes first. PETSc stops at ‖r‖ ≤ max(rtol ‖b‖,
        atol)."""
        if target is not None:
            self.ksp.setTolerances(rtol=0.0, atol=max(target, self.tol * norm), max_it=self.maxiter)
        else:
            self.ksp.setTolerances(rtol=self.tol, atol=0.0, max_it=self.maxiter)

    def destroy(self) -> None:
        """Free the PETSc objects (at exit: `petsc_init.register`)."""
        for obj in (self.ksp, self.A, self._b, self._x, self._local, self._scatter, self._near_nullspace,
                    *self.fields, *self.keep):
            obj.destroy()
        if getattr(self, "_schur", None) is not None:
            self._schur.free()
        if getattr(self, "_velocity", None) is not None:
            self._velocity.destroy()
        unregister(self)

    def _laplacian_basis(self) -> str:
        """The basis in which the pressure Laplacian's AMG ran (`petsc_basis`): "lagrange" or "hierarchical"."""
        schur = getattr(self, "_schur", None)
        return "lagrange" if schur is not None and schur.basis is not None else "hierarchical"

    def progress(self) -> str:
        return f"PETSc {self.iterations[-1] if self.iterations else 0} its"

    def statistics(self) -> dict:
        counts = self.iterations or [0]
        return {"method": self.method, "tolerance": AUTO if self.auto else self.tol,
                "residual": self.residual,
                "setup_seconds": self.factor_seconds, "matvec_seconds": self.matvec_seconds,
                "ranks": self.comm.getSize(),
                "preconditioner": {"ksp": self.options["ksp_type"], "pc": self.ksp.getPC().getType() + " "
                                   + self.options.get("pc_fieldsplit_type", ""),
                                   "velocity": self.options["velocity_preconditioner"],
                                   "stiffness_ratio": self.stiffness_ratio,
                                   "pressure": self.options["schur_approximation"],
                                   "schur_higher_weight": float(self.options["schur_higher_weight"]),
                                   "schur_laplacian_basis": self._laplacian_basis()},
                "iterations": {"mean": float(np.mean(counts)), "max": int(max(counts)), "solves": len(self.iterations)}}
