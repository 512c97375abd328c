"""PETSc's start-up and clean-up, shared by every module that uses PETSc (`petsc`, `mumps`, `symmetric`'s CG).

`petsc()` imports petsc4py and initialises PETSc once per process (`available` says why it cannot); every object
holding PETSc objects is `register`-ed, and destroyed at exit before PETSc finalises (a destructor that reaches
PETSc after that crashes the process).
"""
from __future__ import annotations

import atexit
import weakref

from .base import SolverError

#: The objects holding PETSc objects (each with ``destroy()``), destroyed at exit.
_LIVE: weakref.WeakSet = weakref.WeakSet()
_started = False


def available() -> str | None:
    """None if petsc4py imports here, else why not (one line)."""
    try:
        from petsc4py import PETSc  # noqa: F401
    except ImportError as error:
        return (f"petsc4py does not import ({error}): on Debian or Ubuntu 'make install' installs it "
                "(python3-petsc4py-real); elsewhere 'conda install -c conda-forge petsc4py'")
    return None


def petsc():
    """The ``PETSc`` module, initialised (once per process); `SolverError` if petsc4py is unavailable."""
    global _started
    if reason := available():
        raise SolverError(f"solver: PETSc is unavailable: {reason}")
    import petsc4py

    if not _started:
        petsc4py.init()
        atexit.register(lambda: [holder.destroy() for holder in list(_LIVE)])
        _started = True
    from petsc4py import PETSc

    return PETSc


def register(holder) -> None:
    """Destroy ``holder`` (``holder.destroy()``) at exit, before PETSc finalises, unless it was destroyed before."""
    _LIVE.add(holder)


def unregister(holder) -> None:
    """``holder`` destroyed its PETSc objects itself."""
    _LIVE.discard(holder)
