"""Case values from the command line: ``fsivsp run CASE --set time.dt=1e-4 --set materials.nu=0.01``.

Each ``--set SECTION.KEY=VALUE`` replaces (or adds) one key of the parsed case file before it is validated, so an
override is checked exactly like the file (a bad key or value is the file's one-line error naming it). VALUE is a
TOML value (``1e-4``, ``true``, ``"mini"``, ``["0", "0"]``); a bare word that is not TOML (``taylor_hood``) is
taken as a string. Keys may be nested: ``--set boundary.inflow.traction='["1", "0"]'``.

    doc = apply_overrides(read_toml("case.toml"), parse_overrides(["time.dt=1e-4"]))
"""
from __future__ import annotations

import copy
import re
import tomllib
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from ..errors import CaseError
from .readers import read_toml

#: a bare word taken as a string when it is not a TOML value
WORD = re.compile(r"[A-Za-z_][A-Za-z0-9_\-]*")


def parse_value(text: str, key: str) -> Any:
    """The TOML value of ``text`` (a bare word: that string)."""
    try:
        return tomllib.loads(f"value = {text}")["value"]
    except tomllib.TOMLDecodeError:
        if WORD.fullmatch(text.strip()):
            return text.strip()
        raise CaseError(f"--set {key}: expected a TOML value (a number, true/false, \"text\", [...]), "
                        f"got {text!r}") from None


def parse_override(text: str) -> tuple[str, Any]:
    """``'SECTION.KEY=VALUE'`` → ``('SECTION.KEY', value)``."""
    key, equals, value = text.partition("=")
    key = key.strip()
    if not equals or len(key.split(".")) < 2 or not all(key.split(".")):
        raise CaseError(f"--set: expected SECTION.KEY=VALUE (e.g. time.dt=1e-4), got {text!r}")
    return key, parse_value(value, key)


def parse_overrides(texts: Iterable[str]) -> dict[str, Any]:
    """The ``--set`` options as {dotted key: value}."""
    return dict(parse_override(text) for text in texts)


def apply_overrides(doc: dict, overrides: dict[str, Any]) -> dict:
    """A copy of the case ``doc`` with each dotted key set to its value; a key under a value that is not a table is
    a `CaseError` naming it."""
    doc = copy.deepcopy(doc)
    for key, value in overrides.items():
        *tables, last = key.split(".")
        table = doc
        for depth, name in enumerate(tables):
            table = table.setdefault(name, {})
            if not isinstance(table, dict):
                where = ".".join(tables[:depth + 1])
                raise CaseError(f"--set {key}: {where} is not a table in the case file")
        table[last] = value
    return doc


def case_document(source: str | Path | dict, overrides: dict[str, Any] | None = None) -> tuple[Path, dict]:
    """The path and the parsed, overridden document of a case file, or of a case given as a dict (its path:
    ``case`` in the working directory, so relative file paths are the working directory's)."""
    if isinstance(source, dict):
        return Path("case"), apply_overrides(source, overrides or {})
    return Path(source), apply_overrides(read_toml(source), overrides or {})

