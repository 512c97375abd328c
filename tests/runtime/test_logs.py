"""`fsivsp.runtime.logs`: one handler on stderr, ``warning:``/``error:`` prefixes, warnings through the logger when
not caught, the set-up stages only within `reporting` (or with ``-v``), records of ranks other than 0 dropped."""
import logging
import warnings

import pytest

from fsivsp.runtime import logs, parallel


def test_records_and_prefixes(capsys):
    log = logging.getLogger("fsivsp.some.module")
    log.info("not shown: the default level is WARNING")
    log.warning("a %s", "warning")
    log.error("an error")
    assert capsys.readouterr().err == "warning: a warning\nerror: an error\n"


def test_stages_only_when_reporting(capsys):
    with logs.stage("silent"):
        pass
    with logs.reporting():
        with logs.stage("mesh") as label:
            label[0] = "mesh (renamed)"
    with logs.reporting(False):
        with logs.stage("quiet"):
            pass
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("set-up: mesh (renamed) ") and err[0].endswith(" s"), err


@pytest.mark.parametrize("count, level", [(0, logging.WARNING), (1, logging.INFO), (2, logging.DEBUG),
                                         (5, logging.DEBUG)])
def test_verbosity_is_a_level_within(count, level):
    before = logs.log.level
    with logs.verbosity(count):
        assert logs.log.level == level
    assert logs.log.level == before


def test_dash_v_shows_a_study_s_stages(capsys, examples):
    """``fsivsp study`` is silent on its set-up; with -v each level's stages are logged."""
    from fsivsp.app.cli import main

    case = str(examples / "fluid_over_solid_2d.toml")
    assert main(["study", case, "--levels", "0", "--quiet"]) == 0
    assert "set-up:" not in capsys.readouterr().err
    assert main(["study", case, "--levels", "0", "--quiet", "-v"]) == 0
    stages = [line.split()[1] for line in capsys.readouterr().err.splitlines() if line.startswith("set-up:")]
    assert stages[:2] == ["assembly", "factorisation"], stages


def test_an_uncaught_warning_is_one_line(capsys):
    """`warn` is a `FsivspWarning` (callers may catch or filter it); not caught, the handler writes it."""
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = logs._showwarning
        logs.warn("materials.nu = 1e-06 looks kinematic")
    assert capsys.readouterr().err == "warning: materials.nu = 1e-06 looks kinematic\n"
    with pytest.warns(logs.FsivspWarning, match="looks kinematic"):
        logs.warn("looks kinematic")


def test_other_ranks_write_nothing(capsys, monkeypatch):
    monkeypatch.setattr(parallel, "is_root", lambda: False)
    logging.getLogger("fsivsp").error("rank 1's")
    assert capsys.readouterr().err == ""
