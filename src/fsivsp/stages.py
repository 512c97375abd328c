"""Set-up stage messages of ``fsivsp run``: one line each on stderr with its wall time once it is done,

    set-up: mesh 0.12 s
    set-up: spaces 0.03 s
    set-up: assembly 0.21 s
    set-up: factorisation (pardiso) 0.40 s
    set-up: initial data 0.05 s

printed only inside `reporting` (``fsivsp run`` without ``--quiet``) and by rank 0 under MPI; elsewhere (studies,
the paper's experiment, tests) a `stage` is silent.
"""
from __future__ import annotations

import sys
import time
from contextlib import contextmanager
from typing import Iterator

from . import parallel

_reporting = False


@contextmanager
def reporting(enabled: bool = True) -> Iterator[None]:
    """Within: `stage` prints its line (if ``enabled``)."""
    global _reporting
    previous, _reporting = _reporting, enabled
    try:
        yield
    finally:
        _reporting = previous


@contextmanager
def stage(name: str) -> Iterator[list[str]]:
    """Time the block and print ``set-up: NAME SECONDS s``; the block may rename the stage by setting the yielded
    list's item (e.g. to the solver's method, known only at its end)."""
    label, start = [name], time.perf_counter()
    yield label
    if _reporting and parallel.is_root():
        print(f"set-up: {label[0]} {time.perf_counter() - start:.2f} s", file=sys.stderr, flush=True)
