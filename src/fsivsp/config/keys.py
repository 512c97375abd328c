"""Every key of a case file, documented once: docs/cases.md is rendered from `KEYS` (`markdown`), and the tests
check that every key a reader accepts is here (tests/config/test_keys.py), so the page cannot drift."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Key:
    """One row of the table: ``names`` of ``section`` (``boundary.NAME`` for a boundary's), their ``default`` and
    ``meaning`` (Markdown; links relative to docs/)."""

    section: str
    names: tuple[str, ...]
    default: str
    meaning: str


#: The keys in the order the page shows them.
KEYS: list[Key] = [
    Key('geometry', ('kind',), 'required',
        '`paper_channel`, `fluid_in_solid`, `solid_in_fluid`, `fluid_over_solid`, `elastic_tube`, `mesh`, `cad`'),
    Key('geometry', ('dim',), '2',
        '2 or 3 (`paper_channel`: 2)'),
    Key('geometry', ('maxh',), 'by kind',
        'mesh size: 0.15 `paper_channel`; 0.1 in 2D, 0.2 in 3D (0.3 for `elastic_tube`); `cad`: a tenth of the '
        'bounding box; not for `mesh`'),
    Key('geometry', ('refine',), '0',
        '`run` only: uniform refinements (0–6) of the mesh, new nodes on the true geometry if `curved` (`study` '
        'refines by `--levels`)'),
    Key('geometry', ('grading',), '0.3',
        "`paper_channel`: netgen's grading, in (0, 1]"),
    Key('geometry', ('size', 'radius', 'centre', 'curvature_safety'), '1, 0.25, the middle, 2',
        '`fluid_in_solid`, `solid_in_fluid`: a disk/ball of `radius` in the square/cube (0, `size`)^d'),
    Key('geometry', ('width', 'solid_height', 'fluid_height'), '1, 0.5, 0.5',
        '`fluid_over_solid`: fluid box on a solid box'),
    Key('geometry', ('radius', 'length', 'wall'), '0.5, 5, 0.1',
        '`elastic_tube`: fluid cylinder along x in a solid wall; boundaries `inflow`, `outflow`, `solid_ends`'),
    Key('geometry', ('periodic',), '`""`',
        '`fluid_over_solid`: `"x"` (3D also `"y"`, `"xy"`), `elastic_tube`: `"x"`: the sides across those axes are '
        'the boundary `periodic`, identified (layers, a tube of infinite extent; NGSolve\'s `Periodic` spaces; '
        'serial only) ([docs/frequency.md](frequency.md#periodic-boundaries))'),
    Key('geometry', ('path', 'regions'), 'required, none',
        "relative to the case file's folder; `mesh`: a gmsh `.msh` (2.2/4.x; second-order cells curve the mesh) or "
        'netgen `.vol` file; `cad`: a STEP, BREP or IGES file. `regions` (`mesh`, `cad`) maps cell regions (a CAD '
        'file\'s parts, by name or number) to `fluid` or `solid`, e.g. `{ wall = "solid", plaque = "solid" }`; a '
        'CAD part mapped by a name of its own keeps it ([docs/meshes.md](meshes.md))'),
    Key('materials', ('rho_fluid', 'rho_solid'), 'required',
        'densities ρ_F, ρ_S > 0'),
    Key('materials', ('nu',), 'required',
        'the dynamic viscosity ν > 0 (Pa·s in SI; not ν/ρ): σ_F = −pI + 2ν ε(v) '
        '([docs/commands.md](commands.md#units-and-the-viscosity))'),
    Key('materials', ('lam', 'mu'), 'required',
        'Lamé constants, μ > 0, λ > −2μ/d: σ_S = λ tr ε(u) I + 2μ ε(u)'),
    Key('materials', ('young', 'poisson'), '—',
        '`run` only, instead of `lam`, `mu`: E > 0, −1 < ν_P < 1/2'),
    Key('materials.NAME', ('rho_fluid', 'nu'), '`[materials]`',
        "a fluid cell region's own ([docs/commands.md](commands.md#several-materials))"),
    Key('materials.NAME', ('rho_solid', 'lam', 'mu', 'young', 'poisson'), '`[materials]`',
        "a solid cell region's own (`young`, `poisson`: `run` only); with solid regions of their own, "
        '`initial_stress = "displacement"`'),
    Key('time', ('T', 'dt'), 'required',
        'final time and step, 0 < dt ≤ T'),
    Key('time', ('scheme',), '`"backward_euler"`',
        'the paper\'s (5.1), or `"theta"`, `"bdf2"`: second order, still one matrix per run '
        '([docs/time_schemes.md](time_schemes.md))'),
    Key('time', ('theta',), '0.5',
        '`scheme = "theta"` only: θ in [1/2, 1]; 1/2 is Crank–Nicolson'),
    Key('discretisation', ('family',), '`"mini"`',
        'or `"taylor_hood"`: for large steps in 3D (Δt ≥ 10⁻² on the examples) PETSc\'s iterations stay flat with '
        'Taylor–Hood and grow 13–41 % a level with MINI ([docs/solvers.md](solvers.md#what-is-not-done-yet))'),
    Key('discretisation', ('order',), '1',
        'Taylor–Hood k = 1, 2, 3 (MINI: 1)'),
    Key('discretisation', ('initial_stress',), '`"displacement"`',
        'σ⁰ from the interpolated displacement, or `"projection"`: the L² projection (26)'),
    Key('discretisation', ('initial_velocity',), '`"interpolation"`',
        'or `"projection"`: (22)–(23), discretely divergence-free'),
    Key('discretisation', ('curved',), 'true',
        'isoparametric cells and projected refinement; 3D balls need `curvature_safety` ≥ 2 '
        '([docs/verification.md](verification.md))'),
    Key('discretisation', ('solid_pressure',), '`"auto"`',
        '`"none"`: the paper\'s discretisation; `"continuous"`: the solid keeps a pressure P = −λ Π div u '
        '(σ = 2μ ε(u) − P I), continuous P_k on Ω_S (MINI: P1, with the cell bubble on solid cells too), an '
        'unknown of the step: it does not lock as λ/μ grows, and PETSc\'s iterations stay flat in λ; `"auto"`: '
        '`"continuous"` where some solid region has λ ≥ 10 μ (Poisson\'s ratio ≥ 0.455), else `"none"`; `study` '
        'only for now (`run` keeps `"none"`) ([docs/solvers.md](solvers.md#the-solid-pressure))'),
    Key('discretisation', ('solver',), '`"auto"`',
        '`"direct"`, `"iterative"`, `"petsc"`, `"pardiso"`, `"umfpack"`, `"sparsecholesky"`, `"scipy"`; under mpirun'
        ' `"auto"`, `"petsc"`, `"direct"` (MUMPS), `"iterative"` ([docs/solvers.md](solvers.md))'),
    Key('discretisation', ('tolerance',), '`"auto"`',
        "the iterative solver's tolerance: a number in (0, 1) stops a step's solve at ‖b − Ax‖ ≤ tolerance ‖b‖; "
        '`"auto"` there (1e-12) or where the residual of the step\'s warm start has fallen by 10⁻⁴ (10⁻⁵ for θ = 1/2), '
        'whichever comes first ([docs/solvers.md](solvers.md#tolerance))'),
    Key('discretisation', ('max_iterations',), '2000',
        'per step; beyond it the command stops with exit code 3'),
    Key('discretisation', ('threads',), 'the cores',
        "threads for assembly, set-up and solves (NGSolve's TaskManager, MKL): by default `FSIVSP_THREADS` if set, "
        'else the cores this process may use, divided among the MPI ranks on the node, and one thread for a problem '
        'below 50 000 free unknowns per rank and for a 2D factorisation at any size (where more do not pay); '
        '`--threads N` on `run`, `study`, `paper`, '
        '`matrix` overrides it; bit-identical runs for a given count ([docs/solvers.md](solvers.md#threads))'),
    Key('solver', ('petsc',), 'none',
        'a table of PETSc options for `solver = "petsc"` (or `"iterative"`), without the leading dash, e.g. '
        '`ksp_monitor = true`, `fieldsplit_velocity_pc_type = "gamg"` ([solvers.md](solvers.md#petsc))'),
    Key('exact', ('velocity', 'pressure', 'displacement'), 'required',
        '`study` only: the exact v, p, u (∂t u = v is checked)'),
    Key('data', ('force_fluid', 'force_solid', 'velocity0', 'displacement0'), 'zero',
        'body forces and initial data (`harmonic`: the body forces\' amplitudes, of x, y, z)'),
    Key('boundary.NAME', ('velocity', 'traction'), 'rest on `fluid_wall`, `solid_wall`; else traction-free',
        'Dirichlet v, or σn: `run` of x, y, z, t; `harmonic` of x, y, z (the amplitude); `modes` takes a velocity '
        'boundary at rest, a traction boundary free'),
    Key('boundary.NAME', ('phase',), '0',
        '`harmonic` only: the lag φ in degrees of the datum g(x) cos(2πft − φ) ([docs/frequency.md](frequency.md))'),
    Key('boundary.NAME', ('flow',), '—',
        '`run` only: a flow-rate inflow Q(t) into the domain: an expression of t, or `{ table = "q.csv" }` '
        '(rows time, Q; linear in between), the velocity normal to a straight (2D) or flat circular (3D) boundary '
        'with the discrete flux Q ([docs/commands.md](commands.md#outlets-inflows-and-support))'),
    Key('boundary.NAME', ('profile', 'period', 'harmonics'), '`"parabolic"`, none, 10',
        'with `flow`: `"parabolic"`, `"plug"` or `"womersley"` (from the Fourier series of Q over `period`, '
        '`harmonics` terms, 1–100); `period` also makes a table periodic'),
    Key('boundary.NAME', ('resistance', 'distal_pressure'), '—, 0',
        'an outlet σn = −(P_d + R Q) n, Q = ∫ v·n; P_d a number or an expression of t (`harmonic`: P_d = 0, the '
        'outlet\'s impedance Z = R)'),
    Key('boundary.NAME', ('windkessel',), '—',
        '`{ proximal = R_p, capacitance = C, distal = R_d, distal_pressure = P_d }`: the RCR outlet '
        'C dP_c/dt = Q − (P_c − P_d)/R_d, σn = −(P_c + R_p Q) n (`harmonic`: P_d = 0, Z(s) = R_p + R_d/(1 + sR_dC))'),
    Key('boundary.NAME', ('support',), '—',
        '`{ stiffness = k, damping = c }` on a solid boundary: tissue support σn = −k u − c v (`run`, `harmonic`)'),
    Key('output', ('every',), '10',
        '`run` only: VTK output every so many steps'),
    Key('output', ('probes', 'lines'), 'none',
        'points (every step); `{ start = [...], end = [...], n = 20 }`'),
    Key('output', ('surfaces',), 'none',
        'boundaries (`"interface"` too): flow, mean pressure, area, force every step in `surfaces.csv` and '
        '`surfaces.png`; with `"interface"`, its traction and wall shear stress in `vtk/interface.pvd`'),
    Key('output', ('vtk', 'subdivision'), 'true, 0',
        'write VTU files; their subdivision, 0–3'),
    Key('output', ('continuous',), 'false',
        'one VTU point per mesh vertex (fields averaged over the cells where they live) instead of a copy per cell'),
    Key('checkpoint', ('every',), '50',
        '`run` only: steps between checkpoints'),
    Key('harmonic', ('frequencies',), 'required',
        '`harmonic` only: the frequencies f (cycles per unit time, > 0), a list or `{ start, stop, count, spacing }` '
        '(`spacing` `"linear"` or `"log"`, count numbers from start to stop); [data] force_fluid, force_solid and '
        'the boundaries are then amplitudes of x ([docs/frequency.md](frequency.md))'),
    Key('modes', ('count', 'near'), '6, the lowest',
        '`modes` only (`--count`, `--near` override): how many oscillating modes, nearest which frequency F (the '
        'target s = 2πiF; default: the lowest)'),
]


#: The sections' titles on the page.
SECTIONS = {"geometry": "[geometry]", "materials": "[materials]", "materials.NAME": "[materials.NAME]",
            "time": "[time]",
            "discretisation": "[discretisation]", "solver": "[solver.petsc]", "exact": "[exact]", "data": "[data]",
            "boundary.NAME": "[boundary.NAME]", "output": "[output]", "checkpoint": "[checkpoint]",
            "harmonic": "[harmonic]", "modes": "[modes]"}


def names(section: str) -> set[str]:
    """The keys of ``section`` documented here."""
    return {name for key in KEYS if key.section == section for name in key.names}


def markdown() -> str:
    """The table of docs/cases.md: one row per `Key`, each section's title on its first row."""
    rows, seen = ["| key | default | meaning |", "|---|---|---|"], set()
    for key in KEYS:
        title = "" if key.section in seen else f"**{SECTIONS[key.section]}** "
        seen.add(key.section)
        rows.append(f"| {title}{', '.join(f'`{name}`' for name in key.names)} | {key.default} | {key.meaning} |")
    return "\n".join(rows)
