"""Every file fsivsp writes goes through here: a temporary file in the target's folder, fsync, rename, and an
fsync of the folder, so that a crash, a full disk or a kill never leaves a half-written file in place of a good
one (issue 26). Files get the modes of the umask (0644 under the usual 022), as `open` gives them.

    with atomic.replacing("out/summary.json") as tmp:   # tmp: a Path in out/, renamed onto the target on success
        tmp.write_text(text)
    atomic.write_text("out/summary.json", text)

A failed write raises `WriteError` (an OSError) naming the file and the OS's reason; the temporary file is
removed and the target keeps its earlier contents.
"""
from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Iterator
from pathlib import Path

__all__ = ["WriteError", "replacing", "write_bytes", "write_text", "sync_directory"]


class WriteError(OSError):
    """A file could not be written (full disk, no permission, ...): ``path`` and the OS's ``reason``."""

    def __init__(self, path: Path, error: OSError):
        self.path = Path(path)
        self.reason = error.strerror or str(error)
        super().__init__(error.errno, f"cannot write {self.path}: {self.reason}")

    def __str__(self) -> str:
        return f"cannot write {self.path}: {self.reason}"

    def __reduce__(self):
        """Pickled as its path and reason (a rank's error is raised on every rank, `parallel.together`)."""
        return WriteError, (self.path, OSError(self.errno, self.reason))


def _temporary(path: Path) -> Path:
    """A new empty file next to ``path``, created with the umask's modes (mkstemp would give 0600)."""
    for attempt in range(100):
        tmp = path.with_name(f".{path.name}.{os.getpid()}.{attempt}.tmp")
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            return tmp
        except FileExistsError:
            continue
    raise FileExistsError(f"no free temporary name next to {path}")


def sync_directory(directory: Path) -> None:
    """fsync a folder, so that a rename in it survives a crash (where the filesystem allows it)."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _sync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def replacing(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on a clean exit it is synced and renamed onto ``path``.
    Whatever writes it (numpy, matplotlib, NGSolve's VTKOutput via a name) may write it by name."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = _temporary(path)
    except OSError as error:
        raise WriteError(path, error) from error
    try:
        yield tmp
        _sync_file(tmp)
        os.replace(tmp, path)
    except OSError as error:
        tmp.unlink(missing_ok=True)
        if isinstance(error, WriteError):
            raise
        raise WriteError(path, error) from error
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    sync_directory(path.parent)


def write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with replacing(path) as tmp:
        tmp.write_bytes(data)


def write_text(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    write_bytes(path, text.encode())


def write_json(path: str | Path, data) -> None:
    """``data`` as indented JSON, written atomically."""
    write_text(path, json.dumps(data, indent=2) + "\n")
