"""Faults a long run meets (docs/commands.md, "Exit codes"): SIGTERM in the time loop (checkpoint, summary,
one line, exit 143, resume bit-identical), SIGTERM during set-up (at once, nothing written), a full disk (one
line, exit 4, no half-written file in the series). The signals are sent by the run to itself at a given step,
so that the tests do not race the run."""
import errno
import json
import os
import signal
import xml.etree.ElementTree as ET

import meshio
import pytest

from fsivsp import atomic
from fsivsp.cli import main
from fsivsp.scheme import Scheme

from test_run import write_case


def signal_at_step(monkeypatch, step: int, signum: int = signal.SIGTERM) -> None:
    """The run sends ``signum`` to itself during step ``step``."""
    original = Scheme.step

    def step_and_signal(self, *args, **kwargs):
        if self.n + 1 == step:
            os.kill(os.getpid(), signum)
        return original(self, *args, **kwargs)
    monkeypatch.setattr(Scheme, "step", step_and_signal)


def final(out):
    return json.loads((out / "summary.json").read_text())


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


def test_sigterm_during_set_up_stops_at_once(tmp_path, monkeypatch, capsys):
    def terminated(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGTERM)
        raise AssertionError("the set-up went on after SIGTERM")
    monkeypatch.setattr(Scheme, "__init__", terminated)
    out = tmp_path / "out"
    assert main(["run", str(write_case(tmp_path)), "--out", str(out), "--quiet"]) == 143
    assert capsys.readouterr().err.strip().splitlines() == ["terminated during set-up: nothing written"]
    assert not (out / "checkpoints").exists() and not (out / "summary.json").exists()


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
    assert len(err) == 1 and err[0].startswith(f"skipped {last}: not a readable checkpoint (") \
        and err[0].endswith("resuming from the one before"), err
    assert final(out)["resumed_from"] == 30
