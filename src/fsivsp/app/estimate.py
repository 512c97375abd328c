"""What a run will need, before its mesh is refined: unknowns, memory, time per step and output size
(``fsivsp run`` prints it, refuses a run that does not fit, ``--dry-run`` stops there).

The unknowns are the free dofs of X_h = V_h × Q_h (Section 5.2), counted without building the refined mesh: the
mesh as generated or read gives its vertices, edges, faces and cells (all, fluid, on a Dirichlet boundary), which
each uniform red refinement changes by fixed rules (`Entities`; the fluid cells at the walls follow netgen's pattern,
for Taylor–Hood's bubbles on locked cells), and the spaces' dofs per entity give the count (`Entities.unknowns`):
the refined mesh's unknowns exactly, in milliseconds at any refinement. Under mpirun rank 0 counts. The other
figures are measured laws, fitted on this 2-core machine (the tables below):

- memory = `BASELINE` + N · b(N) · (Taylor–Hood's factor) + the VTK output's part, with b(N) = b₀ (N/N₀)^γ the
  bytes per unknown of the chosen solver (γ = 1/3 for a 3D factorisation, whose fill grows faster than N; N/N₀
  divided by the domain's `aspect` there); the whole process at its peak (ru_maxrss). Under mpirun P ·
  `RANK_BASELINE` + N · `DISTRIBUTED_BYTES_PER_UNKNOWN` + the VTK part, an equal share on every rank, compared
  per node (the ranks that share memory, `parallel.per_node`) with that node's MemAvailable;
- time per step = t₀ (N/N₀)^α, a power law through two rows of BENCHMARKS.md per solver (indicative only: the
  machine's speed drifts by 2–3× between sessions), divided by the ranks under mpirun (ideal);
- output = the VTU files, the checkpoints kept (2, and one being written), the CSV files, the plots and
  ``summary.json``, from bytes per stored value measured on the VTU and checkpoint files of the tests' cases;
  what the folder already holds is replaced, not added (`free_space` counts it as free).
"""
from __future__ import annotations

import logging
import math
import os
from collections import Counter
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path

import numpy as np

from ..config.case import CaseError
from ..geometry import FLUID, SOLID
from ..runtime import parallel

log = logging.getLogger(__name__)

#: The process with fsivsp, NGSolve, MKL and matplotlib loaded and a tiny case run: 252 MiB peak for 883 unknowns
#: (benchmarks/estimate.py, ``ball-3d-mini``); BENCHMARKS.md "Scale": 0.23–0.24 GiB.
BASELINE = 250 * 2**20
#: Per rank under mpirun (each rank loads the same libraries, MPI's and PETSc's too): BENCHMARKS.md "Beyond one
#: node", rank 0's peak with its share of the rows of a small case.
RANK_BASELINE = 300 * 2**20
#: Under mpirun, PETSc's solver (and MUMPS, not measured) over the ranks: the ranks' peaks less their baselines,
#: summed, per free unknown of MINI (docs/mpi.md: 7.0 kB on the 430 568-unknown tube on 3 ranks; BENCHMARKS.md
#: "Beyond one node").
DISTRIBUTED_BYTES_PER_UNKNOWN = 7_000

#: (dimension, solver) → (N₀, b₀, γ): peak − `BASELINE` − the VTK output's part, per free unknown of MINI
#: (`fsivsp run` under ``/usr/bin/time``, benchmarks/estimate.py, session 26, and BENCHMARKS.md "Scale"):
#:
#: ======================  ==========  ===============================================================
#: dimension, solver        N₀, b₀      measured
#: ======================  ==========  ===============================================================
#: 2D, direct               1.7 kB      channel 17 264: 1.6 kB (BENCHMARKS.md "Time schemes": 3.2 kB with
#:                                      VTK and norms)
#: 3D, direct               65 130,     fluid ball 65 130: 11.4 kB (11.1 kB in BENCHMARKS.md, 26 kB at
#:                          11.4 kB,    535 830: the fill grows like N^(1/3)); the tube of
#:                          γ = 1/3     examples/pressure_wave.toml, 57 645: 4.6 kB (a long domain has
#:                                      small separators: b scales with (N / `aspect`)^γ)
#: 3D, PETSc                7.7 kB      the fluid ball with MINI's condensed bubbles (issue 33, BENCHMARKS.md "MINI's
#:                                      bubbles condensed"): 7.2 kB at 65 130 and 535 830, 7.7 kB at 1 640 486
#:                                      (examples/large_ball_3d.toml); the tube 6.3 kB at 249 599 (SSOR: 5.7). Not
#:                                      modelled: BoomerAMG with hypre's elasticity options on a whole MINI block
#:                                      (a solid pressure), 13.8 kB on the ball's 535 830 before the condensation
#: 2D, PETSc               as 3D       not measured (an upper bound: 2D rows are shorter)
#: ======================  ==========  ===============================================================
BYTES_PER_UNKNOWN = {
    (2, "direct"): (1, 1_700, 0.0),
    (3, "direct"): (65_130, 11_400, 1 / 3),
    (2, "petsc"): (1, 7_700, 0.0),
    (3, "petsc"): (1, 7_700, 0.0),
}
#: Taylor–Hood's rows are longer: ×2.0 in 2D (the channel of examples/pressure_wave_2d.toml refined once,
#: 96 807 unknowns: 3.5 kB), ×1.8 in 3D (the fluid ball, level 2, 39 080 unknowns: 17.5 kB against MINI's law's
#: 9.6 kB); measured for k = 1, taken for every k.
FAMILY_FACTOR = {"mini": 1.0, "taylor_hood": 1.9}
#: VTKOutput and meshio's rewrite (`output.postprocess`) of one VTU file, per point: the fluid ball's level 3
#: with and without VTK output, 744 against 507 MiB for 344 064 points.
VTK_BYTES_PER_POINT = 720

#: (dimension, solver) → (N₀, t₀ seconds per step at N₀, α, N₁), BENCHMARKS.md: t₀ (N/N₀)^α up to N₁ and linear
#: beyond it. PETSc's N₁ is the largest size measured: the cost per unknown of its memory-bound step stops growing
#: once the matrices have left the caches (the power law, taken on, was 40× above the linear model of docs/mpi.md
#: at 10⁸ unknowns); a factorisation's fill keeps growing (N₁ infinite).
#: 2D direct from the paper's levels 2 and 4 ("One time step", `march`), 3D direct from the fluid ball's rows of
#: "Scale" (levels 2–3); PETSc from the 3D tube at the default tolerance 1e-12 ("The 3D elastic tube": 3.58 s at
#: 430 568 unknowns, 20.7 s at 1 427 336, 14.5 µs per unknown); the 2D PETSc law is the 3D one (not measured in 2D).
#: Kept as the upper bound since issue 33: at the auto tolerance the tube takes 0.42 s at 282 415 unknowns (SSOR 0.72)
#: (the law: 1.94 s), a step where the stiffness dominates its mass costs what the law says.
SECONDS_PER_STEP = {
    (2, "direct"): (72_339, 1.75e-2, 1.07, math.inf),
    (3, "direct"): (65_130, 0.141, 1.41, math.inf),
    (2, "petsc"): (430_568, 3.58, 1.46, 1_427_336),
    (3, "petsc"): (430_568, 3.58, 1.46, 1_427_336),
}

#: Bytes written per VTU point (zlib-compressed, non-zero fields: the tube of tests/test_run.py 22, the channel
#: of examples/pressure_wave_2d.toml 34, the tube of examples/pressure_wave.toml 70), per unknown of a
#: checkpoint (tests/test_run.py's tube: 26; 31–33 since it keeps xⁿ⁻¹ for the iterative solver's start, issue 33),
#: per CSV value (17–19); plots and summary: a fixed allowance.
VTU_BYTES_PER_POINT = {2: 30, 3: 70}
CHECKPOINT_BYTES_PER_UNKNOWN = 34
CSV_BYTES_PER_VALUE = 20
FIXED_OUTPUT = 150_000


class Refused(CaseError):
    """A run that does not fit (memory, disk): one line, exit code 2, before any work."""


@dataclass(frozen=True)
class Estimate:
    """The figures of one run (``memory`` and ``output`` in bytes; ``memory`` summed over its ``ranks``)."""

    unknowns: int
    cells: int
    solver: str
    memory: int
    seconds_per_step: float
    steps: int
    output: int
    ranks: int = 1

    def line(self) -> str:
        """The one line ``fsivsp run`` prints before set-up."""
        return (f"estimate: {count(self.unknowns)} unknowns ({self.solver}), {gib(self.memory)} memory, "
                f"{seconds(self.seconds_per_step)} per step, {megabytes(self.output)} output")


def _interior(p: int, dim: int) -> np.ndarray:
    """The dofs an H1 space of order ``p`` has inside each vertex, edge, triangle and (3D) tetrahedron."""
    return np.array([1, p - 1, (p - 1) * (p - 2) // 2, (p - 1) * (p - 2) * (p - 3) // 6][:dim + 1])


@dataclass(frozen=True)
class Entities:
    """A mesh's vertices, edges, (3D) faces and cells, each counted as (all, in a fluid cell, on a Dirichlet
    boundary, in a solid cell) in ``counts`` (rows in that order of dimension), and its fluid cells with a vertex on
    a Dirichlet boundary, as many of each kind as ``walled`` says (`_kind`), which give Taylor–Hood's bubbles on
    locked cells (`geometry.locked_fluid_cells`)."""

    dim: int
    counts: np.ndarray
    walled: Counter

    @classmethod
    def of(cls, mesh, dirichlet: str, fluid: str = FLUID, solid: str = SOLID) -> Entities:
        """The counts of ``mesh`` (serial; ``fluid``, ``solid``: the media's region patterns), from the dofs of H1
        spaces of orders 1 to d, which have `_interior` dofs per entity (all: every dof; fluid, solid: the free dofs
        of the space on the medium; Dirichlet: the dofs that are not free)."""
        import ngsolve as ngs

        dim, found = mesh.dim, []
        for order in range(1, mesh.dim + 1):
            plain, wet = ngs.H1(mesh, order=order, dirichlet=dirichlet), ngs.H1(mesh, order=order, definedon=fluid)
            dry = ngs.H1(mesh, order=order, definedon=solid)
            found.append([plain.ndof, wet.FreeDofs().NumSet(), plain.ndof - plain.FreeDofs().NumSet(),
                          dry.FreeDofs().NumSet()])
        cells = [mesh.ne, ngs.L2(mesh, order=0, definedon=fluid).FreeDofs().NumSet(), 0,
                 ngs.L2(mesh, order=0, definedon=solid).FreeDofs().NumSet()]
        shares = np.array([_interior(order, dim)[:dim] for order in range(1, dim + 1)])   # orders × entities
        counts = np.vstack([np.linalg.solve(shares, np.array(found, dtype=float)).round(), cells])
        return cls(dim, counts.astype(np.int64), _walled_cells(mesh, dirichlet, fluid))

    def refined(self, levels: int = 1) -> Entities:
        """The counts after ``levels`` uniform red refinements: a vertex per edge, an edge's two halves, and in each
        triangle 3 new edges and 4 triangles, in each tetrahedron 1 edge, 8 triangles and 8 tetrahedra (new
        entities inside a cell are in the fluid as the cell is, never on the boundary); the walled cells' children
        by netgen's pattern (`geometry.refine.RED`)."""
        counts, walled = self.counts, self.walled
        for _ in range(levels):
            vertices, edges, *faces, cells = counts
            if self.dim == 2:
                counts = np.array([vertices + edges, 2 * edges + 3 * cells, 4 * cells])
            else:
                counts = np.array([vertices + edges, 2 * edges + 3 * faces[0] + cells, 4 * faces[0] + 8 * cells,
                                   8 * cells])
            children = Counter()
            for kind, number in walled.items():
                for child in _children(kind, self.dim):
                    if child[2] or all(child[1]):   # else neither it nor its children are locked
                        children[child] += number
            walled = children
        return Entities(self.dim, counts, walled)

    @property
    def locked(self) -> int:
        """The fluid cells with every vertex on a Dirichlet boundary."""
        return sum(number for (_, corners, _), number in self.walled.items() if all(corners))

    def unknowns(self, family: str, order: int, solid_pressure: bool = False) -> int:
        """The free dofs of X_h (`fem.spaces.build_spaces`): d components of V_h (continuous P_{k+1}, or P1 and a
        bubble per fluid cell for MINI, per cell with a ``solid_pressure``) without its Dirichlet dofs, Q_h
        (continuous P_k on the fluid) and with a ``solid_pressure`` P_h (continuous P_k on the solid)."""
        from ..fem.spaces import base_order

        base, cells = base_order(family, order), self.counts[-1, 0 if solid_pressure else 1]
        velocity = _interior(base, self.dim) @ (self.counts[:, 0] - self.counts[:, 2])
        bubbles = cells if family == "mini" else self.locked if base < self.dim + 1 else 0
        shares = _interior(1 if family == "mini" else order, self.dim)
        pressure = shares @ self.counts[:, 1] + (shares @ self.counts[:, 3] if solid_pressure else 0)
        return int(self.dim * (velocity + bubbles) + pressure)


def _subsets(dim: int) -> list[frozenset]:
    """A cell's edges and (3D) faces as sets of its corners (0 to d)."""
    return [frozenset(sub) for size in range(2, dim + 1) for sub in combinations(range(dim + 1), size)]


def _walled_cells(mesh, dirichlet: str, fluid: str) -> Counter:
    """How many fluid cells (the region pattern ``fluid``) of ``mesh`` with a vertex on a Dirichlet boundary it has
    of each kind: (reversed (`geometry.refine.RED`; none in a generated or read mesh), whether each corner is on a
    Dirichlet boundary, its edges and faces (`_subsets`) that are), the corners in the cell's vertex order."""
    import ngsolve as ngs

    if not dirichlet:
        return Counter()
    region = mesh.Boundaries(dirichlet).Mask()
    facets = [[v.nr for v in el.vertices] for el in mesh.Elements(ngs.BND) if region[el.index]]
    on_wall = {frozenset(sub) for facet in facets for size in range(2, mesh.dim + 1)
               for sub in combinations(facet, size)}   # the Dirichlet edges and (3D) faces, as sets of vertices
    walled = {v for facet in facets for v in facet}
    table = (mesh.ngmesh.Elements3D() if mesh.dim == 3 else mesh.ngmesh.Elements2D()).NumPy()
    cells = table["nodes"][:, :mesh.dim + 1] - 1   # netgen's vertex order, which its refinement follows
    wet = np.array(list(mesh.Materials(fluid).Mask()))[table["index"] - 1]
    kinds = Counter()
    for vertices in cells[wet & np.isin(cells, list(walled)).any(axis=1)].tolist():
        kinds[False, tuple(v in walled for v in vertices),
              frozenset(sub for sub in _subsets(mesh.dim) if frozenset(vertices[i] for i in sub) in on_wall)] += 1
    return kinds


def _children(kind: tuple, dim: int):
    """The kinds (`_walled_cells`) of a walled cell's children by netgen's red refinement (`geometry.refine.RED`):
    a child's corner is on the boundary if it is a corner that is or the midpoint of an edge that is, its edge or
    face if the parent's edge or face it lies in is (an edge or face inside the parent is not)."""
    from ..geometry.refine import RED

    reversed_, corners, dirichlet = kind
    points, children, flags = RED[dim]
    order = (0, 1, 3, 2) if reversed_ else tuple(range(dim + 1))
    spans = [frozenset(order[c] for c in point) for point in points]   # each new point's parent corners
    for child, flag in zip(children, flags):
        if reversed_:
            child, flag = child[:2] + child[:1:-1], not flag
        span = [spans[point] for point in child]
        yield (flag, tuple(corners[min(s)] if len(s) == 1 else s in dirichlet for s in span),
               frozenset(sub for sub in _subsets(dim) if frozenset().union(*(span[i] for i in sub)) in dirichlet))


def count(number: int) -> str:
    """1 799, 1 640 486: thousands apart."""
    return f"{number:,}".replace(",", " ")


def gib(size: float) -> str:
    return f"{size / 2**30:.2f} GiB"


def seconds(time: float) -> str:
    """0.00034 s, 0.024 s, 2.1 s, 140 s."""
    return f"{time:.2g} s" if time < 100 else f"{time:.0f} s"


def megabytes(size: float) -> str:
    return f"{size / 1e6:.1f} MB"


def entities(case) -> Entities:
    """The entity counts of the case's mesh after its ``refine`` refinements still to make."""
    from ..config.boundaries import boundary_conditions, dirichlet

    walls = dirichlet(boundary_conditions(case.boundaries, case.mesh, case.dim))
    return Entities.of(case.mesh, walls, case.phases.pattern(FLUID), case.phases.pattern(SOLID)).refined(case.refine)


def power_law(table: dict, dim: int, solver: str, unknowns: int) -> float:
    """value₀ (N/N₀)^exponent of ``table[dim, solver]`` = (N₀, value₀, exponent, N₁) up to N₁, linear beyond."""
    reference, value, exponent, largest = table[dim, solver]
    within = min(max(unknowns, 1), largest)
    return value * (within / reference) ** exponent * max(unknowns, 1) / within


def aspect(mesh) -> float:
    """How long the domain is: its bounding box's longest side over the geometric mean of the others (1: a cube)."""
    points = np.array([v.point for v in mesh.vertices], dtype=float).reshape(-1, mesh.dim)
    sides = np.sort(np.ptp(points, axis=0))[::-1]
    return float(sides[0] / np.prod(sides[1:]) ** (1 / (len(sides) - 1)))


def vtu_points(case, cells: int) -> int:
    """The points of one VTU file of ``cells`` cells: a copy of every vertex per cell (2^(d·s) cells per cell with
    subdivision s)."""
    return cells * (case.dim + 1) * 2 ** (case.dim * case.output["subdivision"])


def memory_bytes(case, unknowns: int, cells: int, solver: str) -> int:
    """The run's peak memory, summed over the ranks: `BASELINE` (`RANK_BASELINE` per rank under mpirun), the
    solver's bytes per unknown, the VTK output."""
    ranks = parallel.size()
    if ranks > 1:
        solve = unknowns * DISTRIBUTED_BYTES_PER_UNKNOWN
    else:
        reference, per_unknown, exponent = BYTES_PER_UNKNOWN[case.dim, solver]
        solve = unknowns * per_unknown * (max(unknowns, 1) / reference / (aspect(case.mesh) if exponent else 1.0)
                                          ) ** exponent
    vtk = vtu_points(case, cells) * VTK_BYTES_PER_POINT if case.output["vtk"] else 0
    baseline = BASELINE if ranks == 1 else ranks * RANK_BASELINE
    return round(baseline + solve * FAMILY_FACTOR[case.discretisation.family] + vtk)


def output_bytes(case, unknowns: int, cells: int) -> int:
    """The files the run leaves in its folder: VTU series, checkpoints, CSV, plots, summary."""
    output, steps, dim = case.output, case.steps, case.dim
    writes = steps // output["every"] + 1 + (steps % output["every"] > 0)
    vtu = writes * vtu_points(case, cells) * VTU_BYTES_PER_POINT[dim] if output["vtk"] else 0
    checkpoints = min(steps // case.checkpoint_every, 3) * unknowns * CHECKPOINT_BYTES_PER_UNKNOWN  # 2 kept, 1 new
    columns = len(output["probes"]) * (dim + 1) + sum(n for *_, n in output["lines"]) * 2 * (dim + 1) + 2
    return vtu + checkpoints + (steps + 1) * columns * CSV_BYTES_PER_VALUE + FIXED_OUTPUT


def estimate(case) -> Estimate:
    """Every figure of ``case``'s run, from its mesh before its ``refine`` refinements (under mpirun on rank 0,
    whose mesh it is)."""
    from ..fem.spaces import resolve_solid_pressure
    from ..solvers import solver_kind

    found, disc = entities(case), case.discretisation
    solid_pressure = resolve_solid_pressure(disc.solid_pressure, case.materials, case.phases) == "continuous"
    unknowns, cells = found.unknowns(disc.family, disc.order, solid_pressure), int(found.counts[-1, 0])
    solver, ranks = solver_kind(case.solver, unknowns, case.dim), parallel.size()
    return Estimate(unknowns, cells, solver, memory_bytes(case, unknowns, cells, solver),
                    power_law(SECONDS_PER_STEP, case.dim, solver, unknowns) / ranks, case.steps,
                    output_bytes(case, unknowns, cells), ranks)


def proc_bytes(path: str, key: str) -> int | None:
    """The ``key:  N kB`` line of a Linux /proc file in bytes (None where there is none)."""
    try:
        for line in Path(path).read_text().splitlines():
            if line.startswith(f"{key}:"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def available_memory() -> int | None:
    """MemAvailable of /proc/meminfo in bytes (None where there is none)."""
    return proc_bytes("/proc/meminfo", "MemAvailable")


def nearest_existing(out: Path) -> Path:
    """``out`` itself or its nearest parent that exists."""
    return next(p for p in (out, *out.absolute().parents) if p.exists())


def check_output_folder(out: Path, command: str = "run") -> None:
    """``--out`` of ``fsivsp COMMAND``: a folder that is or can be made and written (`Refused` naming it, before
    any work)."""
    if out.exists() and not out.is_dir():
        raise Refused(f"fsivsp {command}: --out {out}: expected a folder, found a file")
    existing = nearest_existing(out)
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        raise Refused(f"fsivsp {command}: --out {out}: {existing} is not a writable folder")


def free_space(out: Path) -> int:
    """Bytes free to this user on the filesystem of ``out`` (or of its nearest existing parent), plus the files
    already in ``out`` (a run into it, or resumed, replaces them)."""
    stat = os.statvfs(nearest_existing(out))
    held = sum(p.stat().st_size for p in out.rglob("*") if p.is_file()) if out.is_dir() else 0
    return stat.f_bavail * stat.f_frsize + held


def fullest_node(figures: Estimate) -> tuple[int, int, int, int | None]:
    """The node (ranks that share memory, `parallel.per_node`) with the least MemAvailable to spare for its ranks'
    shares of the estimated memory: (its number from 1, the nodes, its ranks, its MemAvailable or None). Collective
    under MPI."""
    nodes = parallel.per_node(available_memory)

    def spare(item):
        ranks, available = item[1]
        return float("inf") if available is None else available - figures.memory * ranks / figures.ranks
    number, (ranks, available) = min(enumerate(nodes, start=1), key=spare)
    return number, len(nodes), ranks, available


def node_memory(figures: Estimate, ranks: int) -> int:
    """The estimated memory of ``ranks`` ranks (an equal share each)."""
    return round(figures.memory * ranks / figures.ranks)


def refusals(figures: Estimate, out: Path) -> list[str]:
    """What does not fit: memory over a node's MemAvailable, output over the free space of ``out`` (rank 0's).
    Collective under MPI."""
    number, nodes, ranks, available = fullest_node(figures)
    space = parallel.shared(free_space, out)
    found = []
    if available is not None and node_memory(figures, ranks) > available:
        where = f" on node {number} of {nodes} (its {ranks} of {figures.ranks} ranks)" if nodes > 1 else ""
        found.append(f"estimated memory {gib(node_memory(figures, ranks))}{where} ({count(figures.unknowns)} "
                     f"unknowns, {figures.solver}) exceeds MemAvailable {gib(available)}")
    if figures.output > space:
        found.append(f"--out {out}: {megabytes(space)} free, expected at least the estimated output "
                     f"{megabytes(figures.output)}")
    return found


def report(figures: Estimate, out: Path) -> str:
    """``--dry-run``: the figures, one per line, and what `refusals` would stop (collective under MPI)."""
    lines = [f"unknowns: {count(figures.unknowns)} (solver {figures.solver})",
             f"cells: {count(figures.cells)}",
             f"estimated memory: {gib(figures.memory)}",
             f"estimated time per step: {seconds(figures.seconds_per_step)} ({figures.steps} steps: "
             f"{seconds(figures.seconds_per_step * figures.steps)})",
             f"estimated output: {megabytes(figures.output)} in {out}"]
    if figures.ranks > 1:
        number, nodes, ranks, available = fullest_node(figures)
        free = "unknown" if available is None else gib(available)
        lines.append(f"ranks: {figures.ranks} on {nodes} node{'s' * (nodes > 1)}; the fullest, node {number}: "
                     f"{gib(node_memory(figures, ranks))} for its {ranks} ranks, MemAvailable {free}")
    return "\n".join(lines + [f"would refuse: {reason}; --force runs anyway" for reason in refusals(figures, out)])


def before_run(case, out: Path, dry_run: bool = False, force: bool = False, quiet: bool = False) -> bool:
    """``fsivsp run`` before its mesh is refined: print the estimate (``--dry-run``: the report; True: stop there),
    and raise `Refused` when it does not fit, unless ``force``. Collective under MPI (rank 0 estimates)."""
    figures = parallel.shared(estimate, case)
    if dry_run:
        text = report(figures, out)
        print(text)   # the command's output (other ranks: `parallel.start`)
        return True
    if not quiet:
        log.info("%s", figures.line())
    if not force and (found := refusals(figures, out)):
        raise Refused(f"fsivsp run: {found[0]}; --force runs anyway")
    return False
