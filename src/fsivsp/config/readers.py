"""The low-level readers of a case file's tables, each bad value a one-line `CaseError` naming its field: the TOML
file itself, a table's keys (with a suggestion for a misspelt one), numbers, choices, sections."""
from __future__ import annotations

import difflib
import tomllib
from pathlib import Path

from ..errors import CaseError, is_number


def _suggest(word: str, options) -> str:
    close = difflib.get_close_matches(word, sorted(options), n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def check_keys(table: dict, allowed, where: str) -> None:
    for key in table:
        if key not in allowed:
            raise CaseError(
                f"{where}.{key}: unknown key{_suggest(key, allowed)}; expected one of {', '.join(sorted(allowed))}"
                if where else
                f"{key}: unknown section{_suggest(key, allowed)}; expected one of {', '.join(sorted(allowed))}")


def number(table: dict, key: str, where: str, default=None, minimum: float | None = None, strict: bool = True) -> float:
    """A finite real number, > minimum (or ≥ if not strict)."""
    if key not in table:
        if default is None:
            raise CaseError(f"{where}.{key}: missing; expected a number")
        return default
    value = table[key]
    if not is_number(value):
        raise CaseError(f"{where}.{key}: expected a number, got {value!r}")
    if minimum is not None and (value <= minimum if strict else value < minimum):
        what = "a positive number" if minimum == 0 and strict else f"a number {'>' if strict else '>='} {minimum:g}"
        raise CaseError(f"{where}.{key}: expected {what}, got {value!r}")
    return float(value)


def choice(table: dict, key: str, where: str, options, default):
    value = table.get(key, default)
    if value not in options:
        raise CaseError(f"{where}.{key}: expected one of {', '.join(map(str, options))}, got {value!r}")
    return value


def read_toml(path: str | Path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise CaseError(f"{path}: no such case file")
    try:
        return tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise CaseError(f"{path}: not valid TOML: {str(error).splitlines()[0]}") from None


#: The section that makes a case file a command's own: ``fsivsp study`` has [exact], ``fsivsp harmonic`` [harmonic]
#: (``fsivsp modes`` takes any case but a study's; ``fsivsp run`` a case with neither).
OWN_SECTIONS = {"study": "exact", "harmonic": "harmonic"}


def check_command(doc: dict, path: Path, command: str) -> None:
    """A case file given to another command than its own (`OWN_SECTIONS`): a `CaseError` saying which command to use.
    Only ``fsivsp study`` and ``fsivsp run`` tell a missing section so; ``fsivsp harmonic`` reports its missing
    [harmonic] as any missing section."""
    for other, name in OWN_SECTIONS.items():
        if name in doc and other != command and not (command == "modes" and other == "harmonic"):
            article = "an" if name[0] in "aeiou" else "a"
            raise CaseError(f"{path}: a case for `fsivsp {other}` (it has {article} [{name}] section); "
                            f"use `fsivsp {other} {path}`")
    if command == "study" and "exact" not in doc:
        raise CaseError(f"{path}: a case for `fsivsp run` (it has no [exact] section); use `fsivsp run {path}`")


def section(doc: dict, name: str, required: bool = True) -> dict:
    if name not in doc:
        if required:
            raise CaseError(f"{name}: missing section [{name}]")
        return {}
    if not isinstance(doc[name], dict):
        raise CaseError(f"{name}: expected a table [{name}], got {doc[name]!r}")
    return doc[name]
