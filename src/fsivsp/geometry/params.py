"""Checks of the ``[geometry]`` values (dimensions, positive numbers, points, file paths), each failure a
one-line `GeometryError` naming the field."""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..errors import is_number, is_whole
from .regions import GeometryError

MESH_SUFFIXES = (".msh", ".vol", ".vol.gz")
CAD_SUFFIXES = (".step", ".stp", ".brep", ".iges", ".igs")


def fail(field: str, expected: str, got: Any) -> GeometryError:
    return GeometryError(f"geometry.{field}: expected {expected}, got {got!r}")


def dimension(kind: str, dim: Any, dims: Sequence[int] = (2, 3)) -> int:
    if not is_whole(dim, None) or dim not in dims:
        raise fail("dim", " or ".join(map(str, dims)) + f" for kind '{kind}'", dim)
    return dim


def positive(field: str, value: Any) -> float:
    if not is_number(value) or value <= 0:
        raise fail(field, "a positive number", value)
    return float(value)


def point_parameter(field: str, value: Any, dim: int) -> tuple[float, ...]:
    try:
        point = tuple(value)
    except TypeError:
        raise fail(field, f"a sequence of {dim} numbers", value) from None
    if len(point) != dim or not all(is_number(c) for c in point):
        raise fail(field, f"a sequence of {dim} numbers", value)
    return tuple(float(c) for c in point)


def existing_file(path: str | Path, suffixes: Sequence[str], label: str) -> tuple[Path, str]:
    """The path and its (lower-case) suffix, if it has one of ``suffixes`` and is a file."""
    path = Path(path)
    suffix = next((s for s in suffixes if path.name.lower().endswith(s)), None)
    if suffix is None:
        raise GeometryError(f"{label} {path}: unknown extension '{path.suffix}' "
                            f"(expected one of {', '.join(suffixes)})")
    if not path.is_file():
        raise GeometryError(f"{label} {path}: no such file")
    return path, suffix


def path_parameter(path: Any, suffixes: Sequence[str]) -> str | Path:
    if not isinstance(path, (str, Path)) or not str(path):
        raise fail("path", f"the path of a {', '.join(suffixes)} file", path)
    return path


def one_line(error: BaseException) -> str:
    """A reader's exception as one line: its type and message."""
    return " ".join(f"{type(error).__name__}: {error}".split()).removesuffix(":")
