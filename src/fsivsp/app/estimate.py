"""What a run will need, before it is set up: unknowns, memory, time per step and output size
(``fsivsp run`` prints it, refuses a run that does not fit, ``--dry-run`` stops there).

The unknowns are the free dofs of X_h = V_h × Q_h (Section 5.2), counted on the case's mesh and spaces without
assembling anything. The other figures are measured laws, fitted on this 2-core machine (the tables below):

- memory = `BASELINE` + N · b(N) · (Taylor–Hood's factor) + the VTK output's part, with b(N) = b₀ (N/N₀)^γ the
  bytes per unknown of the chosen solver (γ = 1/3 for a 3D factorisation, whose fill grows faster than N; N/N₀
  divided by the domain's `aspect` there); the whole process at its peak (ru_maxrss); under mpirun the sum over
  the ranks (compared with one machine's MemAvailable);
- time per step = t₀ (N/N₀)^α, a power law through two rows of BENCHMARKS.md per solver (indicative only: the
  machine's speed drifts by 2–3× between sessions);
- output = the VTU files, the checkpoints kept (2, and one being written), the CSV files, the plots and
  ``summary.json``, from bytes per stored value measured on the VTU and checkpoint files of the tests' cases;
  what the folder already holds is replaced, not added (`free_space` counts it as free).
"""
from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..config.case import CaseError
from ..runtime import parallel

log = logging.getLogger(__name__)

#: The process with fsivsp, NGSolve, MKL and matplotlib loaded and a tiny case run: 252 MiB peak for 883 unknowns
#: (benchmarks/estimate.py, ``ball-3d-mini``); BENCHMARKS.md "Scale": 0.23–0.24 GiB.
BASELINE = 250 * 2**20
#: Per rank under mpirun (each rank loads the same libraries, MPI's and PETSc's too; not measured).
RANK_BASELINE = 300 * 2**20

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
#: 3D, PETSc                5.1 kB      BENCHMARKS.md "Scale: PETSc": 5.0 kB at 65 130, 5.1 kB at 535 830
#: 2D, PETSc               as 3D       not measured (an upper bound: 2D rows are shorter)
#: ======================  ==========  ===============================================================
BYTES_PER_UNKNOWN = {
    (2, "direct"): (1, 1_700, 0.0),
    (3, "direct"): (65_130, 11_400, 1 / 3),
    (2, "petsc"): (1, 5_100, 0.0),
    (3, "petsc"): (1, 5_100, 0.0),
}
#: Taylor–Hood's rows are longer: ×2.0 in 2D (the channel of examples/pressure_wave_2d.toml refined once,
#: 96 807 unknowns: 3.5 kB), ×1.8 in 3D (the fluid ball, level 2, 39 080 unknowns: 17.5 kB against MINI's law's
#: 9.6 kB); measured for k = 1, taken for every k.
FAMILY_FACTOR = {"mini": 1.0, "taylor_hood": 1.9}
#: VTKOutput and meshio's rewrite (`output.postprocess`) of one VTU file, per point: the fluid ball's level 3
#: with and without VTK output, 744 against 507 MiB for 344 064 points.
VTK_BYTES_PER_POINT = 720

#: (dimension, solver) → (N₀, t₀ seconds per step at N₀, α), BENCHMARKS.md: 2D direct from the paper's levels 2
#: and 4 ("One time step", `march`), 3D from the fluid ball's rows of "Scale" (direct: levels 2–3) and "Scale:
#: PETSc"; the 2D PETSc law is the 3D one (not measured in 2D).
SECONDS_PER_STEP = {
    (2, "direct"): (72_339, 1.75e-2, 1.07),
    (3, "direct"): (65_130, 0.141, 1.41),
    (2, "petsc"): (65_130, 0.40, 1.61),
    (3, "petsc"): (65_130, 0.40, 1.61),
}

#: Bytes written per VTU point (zlib-compressed, non-zero fields: the tube of tests/test_run.py 22, the channel
#: of examples/pressure_wave_2d.toml 34, the tube of examples/pressure_wave.toml 70), per unknown of a
#: checkpoint (tests/test_run.py's tube: 26), per CSV value (17–19); plots and summary: a fixed allowance.
VTU_BYTES_PER_POINT = {2: 30, 3: 70}
CHECKPOINT_BYTES_PER_UNKNOWN = 30
CSV_BYTES_PER_VALUE = 20
FIXED_OUTPUT = 150_000


class Refused(CaseError):
    """A run that does not fit (memory, disk): one line, exit code 2, before any work."""


@dataclass(frozen=True)
class Estimate:
    """The figures of one run (``memory`` and ``output`` in bytes)."""

    unknowns: int
    solver: str
    memory: int
    seconds_per_step: float
    steps: int
    output: int

    def line(self) -> str:
        """The one line ``fsivsp run`` prints before set-up."""
        return (f"estimate: {count(self.unknowns)} unknowns ({self.solver}), {gib(self.memory)} memory, "
                f"{seconds(self.seconds_per_step)} per step, {megabytes(self.output)} output")


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


def count_unknowns(case) -> int:
    """The free dofs of X_h on the case's mesh (all ranks under MPI), from its spaces alone."""
    from ..config.boundaries import boundary_conditions, dirichlet
    from ..fem.spaces import build_spaces

    disc = case.discretisation
    walls = dirichlet(boundary_conditions(case.boundaries, case.mesh, case.dim))
    return build_spaces(case.mesh, disc.family, disc.order, walls, case.phases).free_dofs()


def power_law(table: dict, dim: int, solver: str, unknowns: int) -> float:
    """value₀ (N/N₀)^exponent of ``table[dim, solver]``."""
    reference, value, exponent = table[dim, solver]
    return value * (max(unknowns, 1) / reference) ** exponent


def aspect(mesh) -> float:
    """How long the domain is: its bounding box's longest side over the geometric mean of the others (1: a cube)."""
    points = np.array([v.point for v in mesh.vertices], dtype=float).reshape(-1, mesh.dim)
    sides = np.sort(np.ptp(points, axis=0))[::-1]
    return float(sides[0] / np.prod(sides[1:]) ** (1 / (len(sides) - 1)))


def vtu_points(case) -> int:
    """The points of one VTU file: a copy of every vertex per cell (2^(d·s) cells per cell with subdivision s)."""
    cells = round(case.mesh.comm.Sum(case.mesh.ne))
    return cells * (case.dim + 1) * 2 ** (case.dim * case.output["subdivision"])


def memory_bytes(case, unknowns: int, solver: str) -> int:
    """The run's peak memory (the sum over the ranks): `BASELINE`, the solver's bytes per unknown, the VTK output."""
    reference, per_unknown, exponent = BYTES_PER_UNKNOWN[case.dim, solver]
    scaled = (max(unknowns, 1) / reference / (aspect(case.mesh) if exponent else 1.0)) ** exponent
    solve = unknowns * per_unknown * scaled * FAMILY_FACTOR[case.discretisation.family]
    vtk = vtu_points(case) * VTK_BYTES_PER_POINT if case.output["vtk"] else 0
    baseline = BASELINE if parallel.size() == 1 else parallel.size() * RANK_BASELINE
    return round(baseline + solve + vtk)


def output_bytes(case, unknowns: int) -> int:
    """The files the run leaves in its folder: VTU series, checkpoints, CSV, plots, summary."""
    output, steps, dim = case.output, case.steps, case.dim
    writes = steps // output["every"] + 1 + (steps % output["every"] > 0)
    vtu = writes * vtu_points(case) * VTU_BYTES_PER_POINT[dim] if output["vtk"] else 0
    checkpoints = min(steps // case.checkpoint_every, 3) * unknowns * CHECKPOINT_BYTES_PER_UNKNOWN  # 2 kept, 1 new
    columns = len(output["probes"]) * (dim + 1) + sum(n for *_, n in output["lines"]) * 2 * (dim + 1) + 2
    return vtu + checkpoints + (steps + 1) * columns * CSV_BYTES_PER_VALUE + FIXED_OUTPUT


def estimate(case) -> Estimate:
    """Every figure of ``case``'s run (collective under MPI)."""
    from ..solvers import solver_kind

    unknowns = count_unknowns(case)
    solver = solver_kind(case.solver, unknowns, case.dim)
    return Estimate(unknowns, solver, memory_bytes(case, unknowns, solver),
                    power_law(SECONDS_PER_STEP, case.dim, solver, unknowns), case.steps, output_bytes(case, unknowns))


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


def refusals(figures: Estimate, out: Path) -> list[str]:
    """What does not fit: memory over MemAvailable, output over the free space of ``out`` (rank 0's machine)."""
    memory, space = parallel.shared(lambda: (available_memory(), free_space(out)))
    found = []
    if memory is not None and figures.memory > memory:
        found.append(f"estimated memory {gib(figures.memory)} ({count(figures.unknowns)} unknowns, {figures.solver}) "
                     f"exceeds MemAvailable {gib(memory)}")
    if figures.output > space:
        found.append(f"--out {out}: {megabytes(space)} free, expected at least the estimated output "
                     f"{megabytes(figures.output)}")
    return found


def report(figures: Estimate, out: Path) -> str:
    """``--dry-run``: the figures, one per line, and what `refusals` would stop."""
    lines = [f"unknowns: {count(figures.unknowns)} (solver {figures.solver})",
             f"estimated memory: {gib(figures.memory)}",
             f"estimated time per step: {seconds(figures.seconds_per_step)} ({figures.steps} steps: "
             f"{seconds(figures.seconds_per_step * figures.steps)})",
             f"estimated output: {megabytes(figures.output)} in {out}"]
    return "\n".join(lines + [f"would refuse: {reason}; --force runs anyway" for reason in refusals(figures, out)])


def before_run(case, out: Path, dry_run: bool = False, force: bool = False, quiet: bool = False) -> bool:
    """``fsivsp run`` before set-up: print the estimate (``--dry-run``: the report; True: stop there), and raise
    `Refused` when it does not fit, unless ``force``."""
    figures = estimate(case)
    if dry_run:
        print(report(figures, out))   # the command's output (other ranks: `parallel.start`)
        return True
    if not quiet:
        log.info("%s", figures.line())
    if not force and (found := refusals(figures, out)):
        raise Refused(f"fsivsp run: {found[0]}; --force runs anyway")
    return False
