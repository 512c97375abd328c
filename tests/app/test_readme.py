"""Every example of README.md and docs/*.md runs (documentation that cannot rot).

``python`` blocks run as scripts (a whole-line ``# ...`` comment right after a ``print`` line is its
expected output); every ``fsivsp`` line of a ``sh`` block is in `COMMANDS`, which says whether it runs
(cheap) or only parses (its case files and paths must exist); the ``console`` example is what the CLI prints.
"""
import importlib.util
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

import fsivsp
from fsivsp.app.cli import build_parser

ROOT = Path(__file__).parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
ENV = {**os.environ, "PYTHONPATH": str(Path(fsivsp.__file__).parents[1])}  # the fsivsp under test
RUN, PARSE = "run", "parse"

#: Every fsivsp command of the docs' sh blocks and how the test checks it: RUN (each under 10 s) or PARSE.
COMMANDS = {
    "fsivsp paper --dt 1e-2 --levels 0-2": RUN,
    "fsivsp study examples/fluid_over_solid_2d.toml --levels 0-1": RUN,
    "fsivsp study examples/time_convergence_2d.toml --dt 0.1,0.05,0.025 --scheme bdf2": RUN,
    "fsivsp study examples/time_convergence_2d.toml --dt 0.1,0.05,0.025,0.0125 --scheme theta --json time.json": PARSE,
    "fsivsp paper --all --scheme bdf2": PARSE,
    "fsivsp run examples/pressure_wave_2d.toml --out wave2d": RUN,
    "fsivsp matrix --slow --readme docs/verification.md": PARSE,
    "fsivsp study examples/fluid_over_solid_2d.toml --levels 0-3 --json study.json": RUN,
    "fsivsp run examples/pressure_wave_2d.toml --out wave2d --resume": RUN,
    "fsivsp run examples/pressure_wave_2d.toml --out wave2d --dry-run": RUN,
    "fsivsp run examples/large_ball_3d.toml --dry-run": PARSE,  # builds the 1.64 million unknowns' mesh
    "fsivsp run examples/pressure_wave_2d.toml --out sweep --set time.T=1e-4 --set materials.nu=0.01": RUN,
    "fsivsp run examples/cad_3d.toml --out cad3d": RUN,
    "fsivsp run examples/channel_2d.toml --out channel2d": RUN,
    "fsivsp run examples/large_ball_3d.toml --out large_ball": PARSE,  # its coarse mesh runs in test_run.py
    "fsivsp run examples/artery_3d.toml --out artery3d": PARSE,  # a few steps run in test_boundaries.py (slow)
    "fsivsp run examples/artery_2d.toml --out artery2d": PARSE,  # a few steps run in test_boundaries.py
    "fsivsp paper --dt 1e-2 --levels 0-4": PARSE,
    "fsivsp paper --dt 1e-3 --levels 2 --json out.json": PARSE,
    "fsivsp paper --all --out paper-report": PARSE,
    "fsivsp paper --dt 1e-2 --initial-stress projection --project": PARSE,
    'fsivsp paper --levels 0-2 --solver petsc --petsc-options "-ksp_type gmres -ksp_gmres_restart 50"': RUN,
    "fsivsp modes examples/modes_2d.toml --out modes2d": RUN,
    "fsivsp harmonic examples/harmonic_3d.toml --out harmonic3d": RUN,
    "fsivsp modes examples/modes_2d.toml --out modes2d --count 4 --near 2.5": PARSE,  # the line above, other options
}


def blocks(language: str) -> list[tuple[str, str]]:
    """(page name, text) of every ```language block of the pages."""
    return [(page.name, text) for page in PAGES
            for text in re.findall(rf"```{language}\n(.*?)```", page.read_text(), re.S)]


def commands() -> list[str]:
    """The fsivsp lines of the sh blocks, without the venv prefix and the comments."""
    lines = [line.split("#")[0].strip().removeprefix(".venv/bin/") for _, text in blocks("sh")
             for line in text.splitlines()]
    return [line for line in lines if line.startswith("fsivsp ")]


@pytest.fixture
def workdir(tmp_path):
    """A folder that links the repository's examples (commands and scripts run from it)."""
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    return tmp_path


PYTHON_BLOCKS = blocks("python")


@pytest.mark.parametrize("page, code", PYTHON_BLOCKS, ids=[f"{page}-{i}" for i, (page, _) in enumerate(PYTHON_BLOCKS)])
def test_python_examples_run(page, code, workdir):
    result = subprocess.run([sys.executable, "-c", code], cwd=workdir, env=ENV, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    lines = code.splitlines()
    expected = [after.removeprefix("# ") for before, after in zip(lines, lines[1:])
                if before.startswith("print(") and after.startswith("# ")]
    if expected:
        assert result.stdout.splitlines() == expected


def test_every_documented_command_is_checked():
    assert sorted(set(commands())) == sorted(COMMANDS)


@pytest.fixture(scope="module")
def check_readme():
    """tools/check_readme.py as a module."""
    spec = importlib.util.spec_from_file_location("check_readme", ROOT / "tools" / "check_readme.py")
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    return tool


def test_check_readme_reads_the_commands_as_pasted(check_readme):
    text = "```sh\n# a comment\nmake demo   # why\n\nfsivsp run a.toml \\\n    --out b\n```\n```python\nx = 1\n```\n"
    assert check_readme.readme_commands(text) == ["make demo   # why", "fsivsp run a.toml --out b"]
    assert check_readme.shown("make demo   # why") == "make demo"


def test_check_readme_skips_the_long_commands(check_readme):
    """Its default skips (`LONG`) are the README's fsivsp commands that are only parsed here."""
    readme = [check_readme.shown(line).removeprefix(".venv/bin/")
              for line in check_readme.readme_commands((ROOT / "README.md").read_text())]
    long = [line for line in readme if any(re.search(p, line) for p in check_readme.LONG)]
    assert [line for line in readme if COMMANDS.get(line) == PARSE] == [line for line in long if line in COMMANDS]


@pytest.mark.parametrize("command", [c for c in COMMANDS if COMMANDS[c] == PARSE])
def test_long_commands_parse(command):
    args = build_parser().parse_args(shlex.split(command)[1:])
    for name in ("case", "readme"):
        if getattr(args, name, None) is not None:
            assert (ROOT / getattr(args, name)).is_file(), f"{command}: no file {getattr(args, name)}"


@pytest.fixture(scope="module")
def ran(tmp_path_factory):
    """``ran(line)``: the folder (linking the examples) where ``line`` has run, once a module, with exit 0."""
    folders: dict[str, Path] = {}

    def run_once(line: str) -> Path:
        if line not in folders:
            folder = tmp_path_factory.mktemp("readme")
            (folder / "examples").symlink_to(ROOT / "examples")
            result = subprocess.run([sys.executable, "-m", "fsivsp", *shlex.split(line)[1:], "--quiet"],
                                    cwd=folder, env=ENV, capture_output=True, text=True)
            assert result.returncode == 0, f"{line}: {result.stderr}"
            folders[line] = folder
        return folders[line]

    return run_once


@pytest.mark.parametrize("command", [c for c in COMMANDS if COMMANDS[c] == RUN])
def test_cheap_commands_run(command, ran):
    """Each in a fresh folder, but a ``--resume`` continues in the folder where its command ran without it (under
    xdist on the same worker: tests/conftest.py, GROUPS)."""
    if not command.endswith(" --resume"):
        ran(command)
        return
    folder = ran(command.removesuffix(" --resume"))
    result = subprocess.run([sys.executable, "-m", "fsivsp", *shlex.split(command)[1:], "--quiet"],
                            cwd=folder, env=ENV, capture_output=True, text=True)
    assert result.returncode == 0, f"{command}: {result.stderr}"


def test_console_example_is_what_the_cli_prints():
    (_, text), = blocks("console")
    command, expected = re.match(r"\$ (.*?)\n(.*)", text, re.S).groups()
    result = subprocess.run([sys.executable, "-m", "fsivsp", *command.split()[1:]], env=ENV,
                            capture_output=True, text=True)
    assert result.returncode == 2
    assert result.stderr.strip() == expected.strip()


@pytest.mark.parametrize("page", PAGES, ids=[page.name for page in PAGES])
def test_relative_links_exist(page):
    targets = [t.split("#")[0] for t in re.findall(r"\]\(([^)]+)\)", page.read_text()) if "://" not in t]
    assert [t for t in targets if t and not (page.parent / t).exists()] == []


def test_matrix_writes_between_the_markers_of_docs_verification(tmp_path, monkeypatch, capsys):
    """``fsivsp matrix --slow --readme docs/verification.md`` replaces the table and nothing else (here an empty matrix
    and one row of the time table)."""
    import fsivsp.experiments.verification
    from fsivsp.app.cli import main

    page = tmp_path / "verification.md"
    text = (ROOT / "docs" / "verification.md").read_text()
    page.write_text(text)
    monkeypatch.setattr(fsivsp.experiments.verification, "TABLE", [])
    monkeypatch.setattr(fsivsp.experiments.verification, "TIME_TABLE",
                        fsivsp.experiments.verification.TIME_TABLE[:1])  # one row, 1–2 s
    assert main(["matrix", "--quiet", "--readme", str(page)]) == 0
    head, table = text.split("<!-- matrix:begin -->\n")[0], capsys.readouterr().out.strip()
    tail = text.split("<!-- matrix:end -->")[1]
    assert page.read_text() == f"{head}<!-- matrix:begin -->\n{table}\n<!-- matrix:end -->{tail}"


def test_matrix_refuses_to_rewrite_the_committed_table_without_slow(capsys):
    """Without ``--slow`` the matrix has fewer rows than docs/verification.md: refused in one line, nothing run."""
    from fsivsp.app.cli import main

    assert main(["matrix", "--quiet", "--readme", str(ROOT / "docs" / "verification.md")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "add --slow" in err[0]
