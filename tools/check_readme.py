"""Run every command of README.md's ``sh``/``bash`` blocks in a fresh clone, as a user pastes them.

    python tools/check_readme.py [CHECKOUT] [--venv PATH] [--skip PATTERN ...] [--timeout SECONDS] [--long]

Clones CHECKOUT (default: the repository holding this script; its committed HEAD) into a temporary folder and
runs each command line there from the clone's root, in order (comment lines skipped, ``\\`` continuations
joined), each with a timeout. Every command is expected to exit 0 (the README shows no failing ``sh`` command;
its failing example is a ``console`` block). At the end ``git status --porcelain`` in the clone must be empty:
the commands write into ignored folders only. Prints a table (command, exit code, seconds) and exits 1 on any
failure. Commands the README documents as long (`LONG`) are skipped unless ``--long``.

``--venv PATH`` links an existing venv as the clone's ``.venv`` instead of letting the README's ``make`` build
it: the clone's files get the venv's modification time (so that make takes it as up to date) and
``PYTHONPATH`` points at the clone's ``src`` (so that the venv runs the clone's fsivsp).
"""
from __future__ import annotations

import argparse
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: Regular expressions of the README commands documented as taking minutes (tests/test_readme.py checks that
#: they cover the fsivsp commands it only parses).
LONG = [r"^make test\b", r"large_ball_3d\.toml", r"artery_3d\.toml", r"fsivsp matrix\b"]


def readme_commands(text: str) -> list[str]:
    """The command lines of the ``sh`` and ``bash`` blocks of ``text``, in order."""
    lines = []
    for block in re.findall(r"^```(?:sh|bash)\n(.*?)^```", text, re.S | re.M):
        for line in re.sub(r"\s*\\\n\s*", " ", block).splitlines():
            if line.strip() and not line.lstrip().startswith("#"):
                lines.append(line.strip())
    return lines


def shown(command: str) -> str:
    """The command without its trailing comment."""
    return re.sub(r"\s+#.*$", "", command)


def run(command: str, cwd: Path, env: dict, timeout: float, log: Path) -> tuple[int | str, float]:
    """(exit code, or "timeout"; seconds) of ``bash -c command``; its output in ``log``."""
    start = time.perf_counter()
    with log.open("w") as output:
        process = subprocess.Popen(["bash", "-c", command], cwd=cwd, env=env, stdout=output,
                                   stderr=subprocess.STDOUT, start_new_session=True)
        try:
            code = process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
            code = "timeout"
    return code, time.perf_counter() - start


def link_venv(clone: Path, venv: Path, env: dict) -> None:
    """Make ``venv`` the clone's ``.venv`` (see the module's docstring)."""
    (clone / ".venv").symlink_to(venv.resolve())
    with (clone / ".git" / "info" / "exclude").open("a") as exclude:
        exclude.write(".venv\n")  # .gitignore's ".venv/" matches a folder, not a link
    mtime = venv.stat().st_mtime
    files = subprocess.run(["git", "ls-files", "-z"], cwd=clone, check=True, capture_output=True, text=True).stdout
    for name in filter(None, files.split("\0")):
        os.utime(clone / name, (mtime, mtime))
    env["PYTHONPATH"] = str(clone / "src")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkout", nargs="?", type=Path, default=Path(__file__).resolve().parents[1],
                        help="the repository to clone (default: this script's)")
    parser.add_argument("--venv", type=Path, help="link this venv as the clone's .venv instead of building one")
    parser.add_argument("--skip", action="append", default=[], metavar="PATTERN",
                        help="skip the commands this regular expression matches (repeatable)")
    parser.add_argument("--long", action="store_true", help="also run the commands documented as long (LONG)")
    parser.add_argument("--timeout", type=float, default=900, help="seconds per command (default 900)")
    args = parser.parse_args(argv)
    skip = args.skip + ([] if args.long else LONG)

    rows, failed = [], False
    with tempfile.TemporaryDirectory(prefix="check_readme-") as folder:
        clone, env = Path(folder) / "clone", dict(os.environ)
        subprocess.run(["git", "clone", "--quiet", str(args.checkout), str(clone)], check=True)
        if args.venv:
            link_venv(clone, args.venv, env)
        for i, command in enumerate(readme_commands((clone / "README.md").read_text())):
            if any(re.search(pattern, shown(command)) for pattern in skip):
                rows.append((shown(command), "skipped", ""))
                continue
            log = Path(folder) / f"command_{i}.log"
            code, seconds = run(command, clone, env, args.timeout, log)
            rows.append((shown(command), str(code), f"{seconds:.1f}"))
            if code != 0:
                failed = True
                print(f"FAILED ({code}): {shown(command)}\n{log.read_text()[-3000:]}", file=sys.stderr)
        status = subprocess.run(["git", "status", "--porcelain"], cwd=clone, check=True, capture_output=True,
                                text=True).stdout
    rows.append(("git status --porcelain", "clean" if not status else "DIRTY", ""))
    width = max(len(row[0]) for row in rows)
    print(f"{'command':{width}}  {'exit':>7}  {'s':>7}")
    for command, code, seconds in rows:
        print(f"{command:{width}}  {code:>7}  {seconds:>7}")
    if status:
        print(f"the README's commands left the clone dirty:\n{status}", file=sys.stderr)
    return 1 if failed or status else 0


if __name__ == "__main__":
    sys.exit(main())
