"""`fsivsp harmonic` and `fsivsp modes` on the command line: their case files checked like every case file (one line
naming the field, exit 2, no traceback), the keys a run case has that they do not read named in one warning, and
Ctrl-C after the current frequency with what was done written."""
import json
import os
import signal

import pytest
from support.frequency import LID, harmonic_case
from support.frequency import fsivsp as command

from fsivsp.app.cli import main
from fsivsp.config.frequency import load_modes_case
from fsivsp.runtime.logs import FsivspWarning

HARMONIC = LID + '\n[harmonic]\nfrequencies = [0.5, 1.0]\n'


def write(tmp_path, text: str):
    path = tmp_path / "case.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("old, new, message", [
    ('velocity = ["16*x**2*(1 - x)**2*(2*y - 1)", "0"]', 'velocity = ["sin(t)*x", "0"]',
     "boundary.fluid_wall.velocity: expected expressions of x, y, z (a harmonic amplitude, the time factor is "
     "cos(2πft − phase): no t), got ['sin(t)*x', '0']"),
    ('force_solid = ["0.5", "-x"]', 'force_solid = ["0.5*t", "-x"]', "data.force_solid: expected expressions of x"),
    ("phase = 90", 'phase = "late"', "boundary.fluid_wall.phase: expected a phase in degrees (a number), got 'late'"),
    ("frequencies = [0.5, 1.0]", "frequencies = [0.5, -1.0]",
     "harmonic.frequencies[1]: expected a positive frequency, got -1.0"),
    ("frequencies = [0.5, 1.0]", "frequencies = [0.5, 0.5]", "harmonic.frequencies: expected distinct frequencies"),
    ("frequencies = [0.5, 1.0]", "frequencies = []", "harmonic.frequencies: expected a list of positive frequencies"),
    ("frequencies = [0.5, 1.0]", "frequencies = { start = 2, stop = 1, count = 3 }",
     "harmonic.frequencies.stop: expected a frequency >= start = 2, got 1"),
    ("frequencies = [0.5, 1.0]", 'frequencies = { start = 1, stop = 2, count = 3, spacing = "cubic" }',
     "harmonic.frequencies.spacing: expected \"linear\" or \"log\", got 'cubic'"),
    ("frequencies = [0.5, 1.0]", "frequencies = { start = 1, stop = 2 }",
     "harmonic.frequencies.count: missing; expected { start, stop, count[, spacing] }"),
    ("[harmonic]\nfrequencies = [0.5, 1.0]", "[harmonic]\nfrequency = 1",
     "harmonic.frequency: unknown key (did you mean 'frequencies'?)"),
    ("[harmonic]\nfrequencies = [0.5, 1.0]", "", "harmonic: missing section [harmonic]"),
    ("[output]", "[exact]\nvelocity = []\n[output]", "a case for `fsivsp study` (it has an [exact] section)"),
    ("[boundary.fluid_wall]", "[boundary.nowhere]", "boundary.nowhere: no boundary of that name in the mesh"),
    ('family = "mini"', 'family = "mini"\nsolver = "petsc"', "discretisation.solver: expected one of auto, direct, "
     "pardiso, umfpack for `fsivsp harmonic` (a factorisation of a complex matrix), got 'petsc'"),
    ("[output]", '[boundary.solid_wall]\nflow = "1"\n\n[output]', "boundary.solid_wall.flow: `fsivsp harmonic` takes "
     "velocity, traction, resistance, windkessel or support on a boundary"),
    ("[output]", "[boundary.solid_wall]\nresistance = 2.0\ndistal_pressure = 1.0\n\n[output]",
     "boundary.solid_wall.distal_pressure: expected 0 in `fsivsp harmonic` (a constant pressure does not oscillate"),
], ids=["t-in-boundary", "t-in-force", "phase", "negative", "twice", "empty", "range", "spacing", "count",
        "misspelt", "no-section", "study-case", "boundary-name", "iterative-solver", "flow-rate", "distal-pressure"])
def test_bad_harmonic_input_is_one_line_and_exit_2(tmp_path, capsys, old, new, message):
    assert old in HARMONIC
    case = write(tmp_path, HARMONIC.replace(old, new))
    assert main(["harmonic", str(case), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and message in err[0], err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("text, message", [
    (HARMONIC.replace("[harmonic]", "[time]\nT = 1.0\ndt = 0.1\n\n[harmonic]"),
     "a case for `fsivsp harmonic` (it has a [harmonic] section); use `fsivsp harmonic"),
    (LID + "\n[time]\nT = 1.0\ndt = 0.1\n", "boundary.fluid_wall.phase: unknown key; expected one of "
                                            "distal_pressure, flow"),
], ids=["harmonic-section", "phase"])
def test_run_refuses_the_frequency_domain_keys(tmp_path, capsys, text, message):
    case = write(tmp_path, text)
    assert main(["run", str(case), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_unused_keys_are_named_in_one_warning(tmp_path, capsys):
    """A run case's [time], [checkpoint], initial data and output.every given to `fsivsp harmonic` are read by no
    one: one warning naming them, and the run goes on."""
    text = HARMONIC.replace("[data]", "[time]\nT = 1.0\ndt = 0.1\n\n[checkpoint]\nevery = 3\n\n[data]\n"
                            'velocity0 = ["x", "0"]').replace("[output]", "[output]\nevery = 4")
    case = write(tmp_path, text.replace("frequencies = [0.5, 1.0]", "frequencies = [0.5]"))
    with pytest.warns(FsivspWarning) as caught:
        assert main(["harmonic", str(case), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    assert [str(w.message) for w in caught] == ["not used by `fsivsp harmonic`: time, checkpoint, data.velocity0, "
                                                "output.every"]
    assert capsys.readouterr().out.startswith("completed: 1 frequencies, 515 unknowns, residuals <= ")


def test_ctrl_c_stops_after_the_current_frequency(tmp_path, capsys, monkeypatch):
    """SIGINT during the second of three frequencies: that solve finishes, harmonic.csv has its two rows, the summary
    says interrupted, one line says where the results are, exit 130."""
    import fsivsp.frequency.harmonic as harmonic

    original, calls = harmonic.respond, []

    def respond(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            os.kill(os.getpid(), signal.SIGINT)
        return original(*args, **kwargs)

    monkeypatch.setattr(harmonic, "respond", respond)
    case = write(tmp_path, HARMONIC.replace("[0.5, 1.0]", "[0.5, 1.0, 1.5]"))
    out = tmp_path / "out"
    assert main(["harmonic", str(case), "--out", str(out), "--quiet"]) == 130
    assert capsys.readouterr().err.strip() == f"interrupted after 2 of 3 frequencies: the results so far are in {out}"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and [s["frequency"] for s in summary["solves"]] == [0.5, 1.0]
    assert len((out / "harmonic.csv").read_text().splitlines()) == 3 and len(calls) == 2


@pytest.mark.parametrize("changes, message", [
    ({"modes.count": 0}, "modes.count: expected a positive whole number, got 0"),
    ({"modes.near": -1}, "modes.near: expected a frequency >= 0, got -1"),
    ({"modes.nearest": 1}, "modes.nearest: unknown key (did you mean 'near'?)"),
    ({"boundary.solid_wall.support": {"stiffness": 1.0}},
     "boundary.solid_wall.support: `fsivsp modes` takes velocity or traction on a boundary"),
])
def test_bad_modes_input(changes, message):
    """`fsivsp modes` reads its case before PETSc is set up (its checks do not need the complex build)."""
    with pytest.raises(Exception, match="^" + message.replace("(", r"\(").replace(")", r"\)").replace("?", r"\?")):
        load_modes_case(harmonic_case(LID, [1.0]), overrides=changes)


@pytest.mark.parametrize("args, message", [
    (["--count", "0"], "argument --count: expected a positive whole number, got '0'"),
    (["--near", "-2"], "argument --near: expected a number >= 0, got '-2'")])
def test_modes_options_are_checked(tmp_path, capsys, args, message):
    assert main(["modes", str(write(tmp_path, HARMONIC)), *args]) == 2
    assert capsys.readouterr().err.strip() == f"error: fsivsp modes: {message}"


def test_modes_of_a_harmonic_case(tmp_path):
    """A harmonic case runs (its loads named unused), --count and --near over the case's."""
    case = write(tmp_path, HARMONIC)
    done = command("modes", case, "--out", tmp_path / "out", "--count", "1", "--near", "1.5", "--quiet")
    assert done.returncode == 0, done.stderr
    assert done.stderr.strip() == ("warning: not used by `fsivsp modes`: data, harmonic, output.probes, "
                                   "boundary.fluid_wall.velocity (its values: the modes take velocity boundaries at "
                                   "rest, traction ones free), boundary.fluid_wall.phase")
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert [round(m["frequency"], 4) for m in summary["modes"]] == [1.4804]


#: ``fsivsp modes`` in which SIGINT arrives before SLEPc's first stopping test (at the end of its first outer
#: iteration), as a user's Ctrl-C during that iteration.
INTERRUPTED = """
import os, signal, sys
import fsivsp.frequency.modes as modes
from fsivsp.app.cli import main
original = modes.coupled_modes
def coupled_modes(*args, stop, **kwargs):
    def interrupted():
        os.kill(os.getpid(), signal.SIGINT)
        return stop()
    return original(*args, stop=interrupted, **kwargs)
modes.coupled_modes = coupled_modes
sys.exit(main(sys.argv[1:]))
"""


def test_ctrl_c_ends_the_eigensolver_with_what_converged(tmp_path):
    """SIGINT during SLEPc's iteration: it stops at the end of the outer iteration (the stopping test), the modes
    converged so far are written (fewer than the 20 asked for: with a basis of 50 vectors they need several
    iterations), the summary says interrupted, one line, exit 130."""
    import subprocess
    import sys

    from support.frequency import ROOT

    script = tmp_path / "interrupted.py"
    script.write_text(INTERRUPTED)
    case = write(tmp_path, LID.split("[data]")[0].replace("maxh = 0.1", "maxh = 0.2")
                 + "\n[solver.petsc]\neps_ncv = 50\n")   # a small basis: several outer iterations
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, str(script), "modes", str(case), "--out", str(out), "--count", "20",
                           "--quiet"], capture_output=True, text=True,
                          env=dict(os.environ, PYTHONPATH=str(ROOT / "src"), FSIVSP_THREADS="1"))
    assert done.returncode == 130, done.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["eigensolver"]["iterations"] == 1
    assert len(summary["modes"]) < 20
    assert done.stderr.strip() == (f"interrupted after {len(summary['modes'])} of 20 modes: the results so far are "
                                   f"in {out}")
    assert (out / "modes.csv").is_file()
