"""Faults a long run meets (docs/commands.md, "Exit codes"): SIGTERM in the time loop (checkpoint, summary,
one line, exit 143, resume bit-identical), SIGTERM or SIGINT during set-up (at once, nothing written), a full disk (one
line, exit 4, no half-written file in the series). The signals are sent by the run to itself at a given step,
so that the tests do not race the run."""
import errno
import os
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import pytest
from support.cases import final, signal_at_step, write_case

from fsivsp.app.cli import main
from fsivsp.io import atomic
from fsivsp.timestepping.scheme import Scheme

ROOT = Path(__file__).parents[2]


@pytest.mark.parametrize("signum, code, status", [(signal.SIGTERM, 143, "terminated"),
                                                  (signal.SIGINT, 130, "interrupted")])
def test_signal_in_the_loop_then_resume_is_bit_identical(tmp_path, monkeypatch, capsys, signum, code, status):
    case = write_case(tmp_path, T=0.002, every=1000)   # 40 steps, periodic checkpoints never
    assert main(["run", str(case), "--out", str(tmp_path / "whole"), "--quiet"]) == 0
    with monkeypatch.context() as patch:
        signal_at_step(patch, 13, signum)
        assert main(["run", str(case), "--out", str(tmp_path / "cut"), "--quiet"]) == code
    err = capsys.readouterr().err.strip().splitlines()
    checkpoint = tmp_path / "cut" / "checkpoints" / "checkpoint_000013.npz"
    assert err == [f"{status} at step 13 (t = 0.00065): checkpoint {checkpoint}; continue with --resume"]
    assert final(tmp_path / "cut")["status"] == status and final(tmp_path / "cut")["step"] == 13
    assert main(["run", str(case), "--out", str(tmp_path / "cut"), "--resume", "--quiet"]) == 0
    whole, resumed = final(tmp_path / "whole"), final(tmp_path / "cut")
    assert resumed["resumed_from"] == 13 and resumed["step"] == whole["step"] == 40
    assert resumed["l2_norms"] == whole["l2_norms"]        # bit for bit (the direct solver)
    assert resumed["energy"] == whole["energy"]


def test_a_signal_ignored_from_the_start_stays_ignored(tmp_path, monkeypatch, capsys):
    """SIGINT ignored when the run starts (a background job of a script): Ctrl-C at step 13 leaves it running to the
    end, as the uninterrupted run; SIGTERM still stops it after the step."""
    case = write_case(tmp_path, T=0.002, every=1000)   # 40 steps
    signal.signal(signal.SIGINT, signal.SIG_IGN)   # the autouse fixture restores the handler
    with monkeypatch.context() as patch:
        signal_at_step(patch, 13, signal.SIGINT)
        assert main(["run", str(case), "--out", str(tmp_path / "ignored"), "--quiet"]) == 0
    assert final(tmp_path / "ignored")["status"] == "completed" and final(tmp_path / "ignored")["step"] == 40
    assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN   # left as it was found
    with monkeypatch.context() as patch:
        signal_at_step(patch, 13, signal.SIGTERM)
        assert main(["run", str(case), "--out", str(tmp_path / "terminated"), "--quiet"]) == 143
    assert final(tmp_path / "terminated")["step"] == 13
    checkpoint = tmp_path / "terminated" / "checkpoints" / "checkpoint_000013.npz"
    assert capsys.readouterr().err.strip().splitlines() == [   # nothing from the ignored SIGINT
        f"terminated at step 13 (t = 0.00065): checkpoint {checkpoint}; continue with --resume"]


@pytest.mark.parametrize("signum, code, line", [(signal.SIGTERM, 143, "terminated during set-up: nothing written"),
                                                (signal.SIGINT, 130, "interrupted during set-up: nothing written")])
def test_signal_during_set_up_stops_at_once(tmp_path, monkeypatch, capsys, signum, code, line):
    def stopped(*args, **kwargs):
        os.kill(os.getpid(), signum)
        raise AssertionError("the set-up went on after the signal")
    monkeypatch.setattr(Scheme, "__init__", stopped)
    out = tmp_path / "out"
    assert main(["run", str(write_case(tmp_path)), "--out", str(out), "--quiet"]) == code
    assert capsys.readouterr().err.strip().splitlines() == [line]
    assert not out.exists() or list(out.iterdir()) == []   # no checkpoints, no summary.json, no series


@pytest.mark.parametrize("command", [["study", str(ROOT / "examples" / "fluid_over_solid_2d.toml"), "--levels", "0-1"],
                                     ["paper", "--dt", "1e-2", "--levels", "0-1"]], ids=["study", "paper"])
def test_ctrl_c_in_study_and_paper_is_one_line(monkeypatch, capsys, command):
    signal_at_step(monkeypatch, 2, signal.SIGINT)
    assert main([*command, "--quiet"]) == 130
    assert capsys.readouterr().err.strip().splitlines() == ["interrupted"]


def _signal_mask(pid: int, field: str) -> int:
    """``field`` (SigIgn, SigCgt) of /proc/pid/status as a bit mask (bit n − 1 for signal n); 0 once it has gone."""
    try:
        lines = Path(f"/proc/{pid}/status").read_text().splitlines()
    except (FileNotFoundError, ProcessLookupError):
        return 0
    return next(int(line.split()[1], 16) for line in lines if line.startswith(f"{field}:"))


def catches_sigint(pid: int) -> bool:
    return bool(_signal_mask(pid, "SigCgt") >> (signal.SIGINT - 1) & 1)


def ignores_sigint(pid: int) -> bool:
    return bool(_signal_mask(pid, "SigIgn") >> (signal.SIGINT - 1) & 1)


def children(pid: int) -> list[int]:
    return [int(child) for child in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]


def test_ctrl_c_in_paper_all_stops_its_workers_without_a_traceback(tmp_path):
    """Ctrl-C reaches the terminal's whole process group: the workers ignore it, the parent ends them."""
    paper = subprocess.Popen([sys.executable, "-m", "fsivsp", "paper", "--all", "--levels", "0-1", "--jobs", "2",
                              "--quiet", "--out", str(tmp_path)], stderr=subprocess.PIPE, text=True,
                             start_new_session=True, env={**os.environ, "PYTHONPATH": str(ROOT / "src")})
    # Not after a sleep: once the pool is made, the parent catches SIGINT again and its workers ignore it (the
    # spawned processes inherit SIG_IGN), which /proc shows; then the signal cannot race their start.
    while not (catches_sigint(paper.pid) and sum(ignores_sigint(child) for child in children(paper.pid)) >= 2):
        assert paper.poll() is None, paper.communicate()
        time.sleep(0.05)
    os.killpg(paper.pid, signal.SIGINT)
    assert paper.wait() == 130
    assert paper.stderr.read().strip().splitlines() == ["interrupted"]


def test_full_disk_stops_with_one_line_and_leaves_a_readable_series(tmp_path, monkeypatch, capsys):
    """The disk fills while step 20's VTU file is written (ENOSPC at its fsync): exit 4, one line naming the file,
    the OS's reason and the last good checkpoint; the series keeps only whole files, each one readable."""
    sync = atomic._sync_file

    def full(path):
        if "fields_000020" in path.name:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        sync(path)
    monkeypatch.setattr(atomic, "_sync_file", full)
    out = tmp_path / "out"
    assert main(["run", str(write_case(tmp_path, every=10)), "--out", str(out), "--quiet"]) == 4
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"error: cannot write {out / 'vtk' / 'fields_000020.vtu'}: No space left on device; "
                   f"last good checkpoint: {out / 'checkpoints' / 'checkpoint_000010.npz'}"]
    vtk = out / "vtk"
    assert not [p.name for p in vtk.iterdir() if p.name.startswith(".")]   # no temporary file left
    listed = [ds.get("file") for ds in ET.parse(vtk / "fields.pvd").getroot().iter("DataSet")]
    assert listed == [f"fields_{n:06d}.vtu" for n in (0, 10)] and not (vtk / "fields_000020.vtu").exists()
    for name in listed:
        assert len(meshio.read(vtk / name).points) > 0


def test_out_on_a_file_or_an_unwritable_folder(tmp_path, capsys):
    taken = tmp_path / "taken"
    taken.write_text("")
    assert main(["run", str(write_case(tmp_path)), "--out", str(taken), "--quiet"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"error: fsivsp run: --out {taken}: expected a folder, found a file"]
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    if os.access(locked, os.W_OK):  # root writes anywhere: make it a file's child instead
        locked = taken / "below"
    assert main(["run", str(write_case(tmp_path)), "--out", str(locked / "out"), "--quiet"]) == 2
    assert "is not a writable folder" in capsys.readouterr().err


def test_resume_reports_a_corrupt_last_checkpoint(tmp_path, capsys):
    """A truncated last checkpoint is passed over with one line, and the run resumes from the one before."""
    case = write_case(tmp_path, T=0.002, every=10)
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out), "--quiet"]) == 0
    last = out / "checkpoints" / "checkpoint_000040.npz"
    last.write_bytes(last.read_bytes()[:1000])
    capsys.readouterr()
    assert main(["run", str(case), "--out", str(out), "--resume", "--quiet"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"warning: skipped {last}: not a readable checkpoint (") \
        and err[0].endswith("resuming from the one before"), err
    assert final(out)["resumed_from"] == 30
