"""The estimate before set-up (`fsivsp.estimate`): the unknowns and cells of the refined mesh counted from the mesh
before refinement, within a factor 1.5 of the measured peak memory on a 2D and a 3D case, ``--dry-run`` (prints,
writes nothing, exit 0), the one estimate line, and the refusals (memory over MemAvailable, output over the free
space: one line, exit 2, nothing written; ``--force`` runs anyway)."""
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from support.cases import CASE, write_case

from fsivsp.app import estimate
from fsivsp.app.cli import main
from fsivsp.config.production import load_run_case

TIME = shutil.which("time", path="/usr/bin")
ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
from estimate import case_text  # noqa: E402  (benchmarks/estimate.py: the calibration's cases)


def peak_of_run(case: Path, out: Path) -> int:
    """ru_maxrss of ``fsivsp run case`` in a child of /usr/bin/time (whose own child starts small: a child of
    this large process would report this process's peak, BENCHMARKS.md "Time schemes"), in bytes."""
    done = subprocess.run([TIME, "-f", "%M", sys.executable, "-m", "fsivsp", "run", str(case), "--out", str(out),
                           "--quiet", "--force"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return int(done.stderr.split()[-1]) * 1024


@pytest.mark.skipif(TIME is None, reason="no /usr/bin/time")
@pytest.mark.parametrize("example, refine, discretisation, steps", [
    ("pressure_wave_2d.toml", 1, 'family = "taylor_hood"', 3),       # 96 807 unknowns, direct
    ("pressure_wave.toml", 0, 'family = "mini"', 2),                 # 32 242 unknowns, direct (maxh 0.13)
], ids=["2d", "3d"])
def test_memory_within_a_factor_1_5_of_the_peak(tmp_path, example, refine, discretisation, steps):
    case = tmp_path / "case.toml"
    case.write_text(case_text(example, refine, discretisation, steps).replace("maxh = 0.1\n", "maxh = 0.13\n"))
    figures = estimate.estimate(load_run_case(case))
    peak = peak_of_run(case, tmp_path / "out")
    assert 1 / 1.5 <= figures.memory / peak <= 1.5, (figures, peak)


@pytest.mark.parametrize("example, refine, discretisation", [
    ("pressure_wave_2d.toml", 2, 'family = "mini"'),                       # Dirichlet ends, traction walls
    ("fluid_over_solid_2d.toml", 2, 'family = "taylor_hood"'),             # bubbles on locked corner cells
    ("fluid_in_solid_2d.toml", 1, 'family = "taylor_hood"\norder = 3'),
    ("fluid_over_solid_3d.toml", 2, 'family = "mini"'),                    # fluid and solid walls
    ("solid_in_fluid_3d.toml", 2, 'family = "taylor_hood"\ncurved = false'),  # locked cells along the box's edges
    ("pressure_wave_2d.toml", 2, 'family = "mini"\nsolid_pressure = "continuous"'),   # bubbles on every cell
    ("fluid_in_solid_2d.toml", 1, 'family = "taylor_hood"\norder = 2\nsolid_pressure = "continuous"'),
], ids=["tube-2d-mini", "box-2d-th1", "disk-2d-th3", "box-3d-mini", "ball-3d-th1", "tube-2d-mini-solid-pressure",
        "disk-2d-th2-solid-pressure"])
def test_unknowns_and_cells_of_the_refined_mesh(tmp_path, example, refine, discretisation):
    """Counted from the mesh before refinement (`estimate.Entities`), the refined mesh's cells and free unknowns,
    exactly as its spaces have them."""
    from fsivsp.config.boundaries import boundary_conditions, dirichlet
    from fsivsp.fem.spaces import build_spaces, resolve_solid_pressure

    case = tmp_path / "case.toml"
    case.write_text(case_text(example, refine, discretisation, 1))
    figures = estimate.estimate(load_run_case(case, coarse=True))
    built = load_run_case(case)
    walls = dirichlet(boundary_conditions(built.boundaries, built.mesh, built.dim))
    disc = built.discretisation
    assert figures.cells == built.mesh.ne
    solid_pressure = resolve_solid_pressure(disc.solid_pressure, built.materials, built.phases)
    spaces = build_spaces(built.mesh, disc.family, disc.order, walls, built.phases, solid_pressure=solid_pressure)
    assert figures.unknowns == spaces.free_dofs()


def test_output_estimate_within_a_factor_2_of_the_files(tmp_path):
    out = tmp_path / "out"
    case = write_case(tmp_path)
    figures = estimate.estimate(load_run_case(case))
    assert main(["run", str(case), "--out", str(out), "--quiet"]) == 0
    written = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    assert 0.5 <= figures.output / written <= 2, (figures.output, written)


def test_dry_run_prints_the_figures_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", str(write_case(tmp_path)), "--out", str(out), "--dry-run"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert [line.split(":")[0] for line in lines] == ["unknowns", "cells", "estimated memory",
                                                      "estimated time per step", "estimated output"], lines
    assert lines[0] == "unknowns: 1 799 (solver direct)" and not out.exists()


@pytest.fixture
def no_run(monkeypatch):
    """`runner.run_case` replaced by a stub: what happens before set-up, without the run."""
    calls = []

    def run_case(case, out, **options):
        calls.append(out)
        return {"status": "completed", "step": 0, "time": 0.0, "threads": 1}
    monkeypatch.setattr("fsivsp.app.api.run_case", run_case)
    return calls


def test_run_prints_one_estimate_line_unless_quiet(tmp_path, capsys, no_run):
    case = write_case(tmp_path)
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 0
    assert [line for line in capsys.readouterr().err.splitlines() if line.startswith("estimate:")] == [
        "estimate: 1 799 unknowns (direct), 0.25 GiB memory, 0.00034 s per step, 0.6 MB output"]
    assert main(["run", str(case), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    assert "estimate:" not in capsys.readouterr().err and len(no_run) == 2


def test_more_than_mem_available_is_refused_unless_forced(tmp_path, capsys, monkeypatch, no_run):
    monkeypatch.setattr(estimate, "available_memory", lambda: 100 * 2**20)
    out = tmp_path / "out"
    assert main(["run", str(write_case(tmp_path)), "--out", str(out), "--quiet"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        "error: fsivsp run: estimated memory 0.25 GiB (1 799 unknowns, direct) exceeds MemAvailable 0.10 GiB; "
        "--force runs anyway"]
    assert not no_run and not out.exists()
    assert main(["run", str(write_case(tmp_path)), "--out", str(out), "--quiet", "--force"]) == 0 and no_run


def test_dry_run_names_what_would_be_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(estimate, "available_memory", lambda: 100 * 2**20)
    assert main(["run", str(write_case(tmp_path)), "--out", str(tmp_path / "out"), "--dry-run"]) == 0
    assert capsys.readouterr().out.strip().splitlines()[-1].startswith("would refuse: estimated memory 0.25 GiB")


def frames_every_step(tmp_path) -> Path:
    """The tube of test_run with a VTU file at every one of its 40 steps: about 1.5 MB of output."""
    case = tmp_path / "frames.toml"
    case.write_text(CASE.format(T=0.002, every=50).replace("every = 10\nprobes", "every = 1\nprobes"))
    return case


def test_less_free_space_than_the_output_is_refused(tmp_path, tiny_disk, capsys, no_run):
    out = tiny_disk / "out"
    assert main(["run", str(frames_every_step(tmp_path)), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: fsivsp run: --out {out}: 0.7 MB free, expected at least "
                                               "the estimated output "), err
    assert not no_run and not list(tiny_disk.iterdir())


def test_files_already_in_the_folder_count_as_free(tiny_disk):
    """A run into a folder (or resumed there) replaces its files: their bytes count as free."""
    out = tiny_disk / "out"
    out.mkdir()
    before = estimate.free_space(out)
    (out / "old.vtu").write_bytes(b"x" * 100_000)
    assert abs(estimate.free_space(out) - before) <= 4096 and before > 600_000   # one block of the tmpfs


def test_help_names_the_new_options(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = capsys.readouterr().out
    assert "--dry-run" in text and "--force" in text and "MemAvailable" in text
