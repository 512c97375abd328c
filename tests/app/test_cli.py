"""The command line: `fsivsp paper` output and one-line errors with exit code 2."""
import json
import subprocess
import sys

import pytest

from fsivsp.app.cli import main


def run(*args):
    return subprocess.run([sys.executable, "-m", "fsivsp", *args], capture_output=True, text=True)


def test_paper_prints_tables_and_writes_json(tmp_path):
    out = tmp_path / "paper.json"
    result = run("paper", "--dt", "1e-1", "--levels", "0-1", "--quiet", "--json", str(out))
    assert result.returncode == 0, result.stderr
    assert "e(v1)" in result.stdout and "r(σ)" in result.stdout and "(0.879222)" in result.stdout
    records = json.loads(out.read_text())
    assert [r["level"] for r in records] == [0, 1]
    for record in records:
        assert set(record["errors"]) == {"v1", "v2", "p", "sigma", "total"}
        assert set(record["seconds"]) == {"assembly", "factorisation", "time_loop"}
        assert record["dofs"] > 0
    assert records[0]["rates"]["v1"] is None and records[1]["rates"]["v1"] > 0


@pytest.mark.parametrize("args, field", [
    (["paper", "--dt", "-1"], "--dt"),
    (["paper", "--dt", "abc"], "--dt"),
    (["paper", "--dt", "0"], "--dt"),
    (["paper", "--levels", "3-1"], "--levels"),
    (["paper", "--levels", "0-9"], "--levels"),
    (["paper", "--levels", "a-b"], "--levels"),
    (["paper", "--jobs", "0"], "--jobs"),
    (["paper", "--initial-stress", "zero"], "--initial-stress"),
    (["paper", "--solver", "magic"], "--solver"),
    (["paper", "--bogus"], "--bogus"),
    (["frobnicate"], "frobnicate"),
])
def test_bad_input_is_one_line_and_exit_2(args, field, capsys):
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and field in err and "Traceback" not in err


def test_help_on_every_command(capsys):
    for args in (["--help"], ["paper", "--help"]):
        with pytest.raises(SystemExit) as stop:
            main(args)
        assert stop.value.code == 0
    assert "--levels" in capsys.readouterr().out
