"""fsivsp's messages: the ``fsivsp`` logger and its one handler, warnings, and the set-up stages.

Library code logs (``log = logging.getLogger(__name__)``) and warns (`warn`, a `FsivspWarning`); what it prints
is the command's own output (tables, the final line). The handler writes to stderr on rank 0 only (under MPI the
other ranks' records are dropped, as Firedrake does), a record as its message, a warning as ``warning: ...`` and
an error as ``error: ...``; a `FsivspWarning` not caught by the caller is logged the same way. The level is
WARNING, INFO within `reporting` (``fsivsp run`` and ``fsivsp.run`` unless quiet: the estimate and the set-up
stages, `stage`), and the command line's ``-v`` (INFO everywhere) or ``-vv`` (DEBUG) (`verbosity`):

    set-up: mesh 0.12 s
    set-up: spaces 0.03 s
    set-up: assembly 0.21 s
    set-up: factorisation (pardiso) 0.40 s
    set-up: initial data 0.05 s
"""
from __future__ import annotations

import logging
import sys
import time
import warnings
from collections.abc import Iterator
from contextlib import contextmanager

from . import parallel

log = logging.getLogger("fsivsp")


class FsivspWarning(UserWarning):
    """A case that runs but looks wrong (a kinematic-looking viscosity, a path found elsewhere)."""


def warn(message: str) -> None:
    """Warn about the caller's input: a `FsivspWarning` (``warning: MESSAGE`` on stderr unless caught)."""
    warnings.warn(message, FsivspWarning, stacklevel=3)


class _Stderr(logging.StreamHandler):
    """stderr as it is when a record is emitted (tests and `parallel.start` replace it)."""

    def __init__(self):
        super().__init__()
        self.addFilter(lambda record: parallel.is_root())

    @property
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, value):
        pass


class _Format(logging.Formatter):
    PREFIX = {logging.WARNING: "warning: ", logging.ERROR: "error: ", logging.CRITICAL: "error: "}

    def format(self, record: logging.LogRecord) -> str:
        return self.PREFIX.get(record.levelno, "") + record.getMessage()


_handler = _Stderr()
_handler.setFormatter(_Format())
log.addHandler(_handler)
log.setLevel(logging.WARNING)
log.propagate = False
_show = warnings.showwarning


def _showwarning(message, category, filename, lineno, file=None, line=None):
    if issubclass(category, FsivspWarning):
        log.warning("%s", message)
    else:
        _show(message, category, filename, lineno, file, line)


warnings.showwarning = _showwarning

#: The command line's verbosity (``-v`` counted) as a level of the ``fsivsp`` logger.
LEVELS = {0: logging.WARNING, 1: logging.INFO, 2: logging.DEBUG}


@contextmanager
def verbosity(count: int = 0) -> Iterator[None]:
    """Within: the ``fsivsp`` logger's level for a command's ``-v`` count (`LEVELS`); the level before, after."""
    previous = log.level
    log.setLevel(LEVELS[max(0, min(2, count))])
    try:
        yield
    finally:
        log.setLevel(previous)


@contextmanager
def reporting(enabled: bool = True) -> Iterator[None]:
    """Within: INFO records (the set-up stages) are written if ``enabled``, else only warnings and errors."""
    previous = log.level
    log.setLevel(min(previous, logging.INFO) if enabled else max(previous, logging.WARNING))
    try:
        yield
    finally:
        log.setLevel(previous)


@contextmanager
def stage(name: str) -> Iterator[list[str]]:
    """Time the block and log ``set-up: NAME SECONDS s`` (INFO); the block may rename the stage by setting the
    yielded list's item (e.g. to the solver's method, known only at its end)."""
    label, start = [name], time.perf_counter()
    yield label
    log.info("set-up: %s %.2f s", label[0], time.perf_counter() - start)
