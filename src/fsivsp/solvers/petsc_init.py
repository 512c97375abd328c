"""PETSc's start-up and clean-up, shared by every module that uses PETSc (`petsc`, `mumps`, `symmetric`'s CG, the
frequency domain's SLEPc eigensolver, `frequency.modes`).

`petsc()` imports petsc4py and initialises PETSc once per process (`available` says why it cannot), `slepc()` does
the same for slepc4py; every object holding PETSc objects is `register`-ed, and destroyed at exit before PETSc
finalises (a destructor that reaches PETSc after that crashes the process).

**Real or complex scalars: one build per process.** PETSc is compiled for one scalar type. Debian installs the real
build on the venv's path (its ``petsc4py-system.pth``) and the complex one beside it (`COMPLEX_PATHS`:
python3-petsc4py-complex, python3-slepc4py-complex); whichever petsc4py is imported first is the process's. A
command that needs complex scalars (``fsivsp modes``: a shift at s = 2πiF) calls `use("complex")` when it starts,
before anything imports petsc4py, which puts the complex build first on ``sys.path``; NGSolve is indifferent. Asking
for the other build later is a `SolverError` naming both.
"""
from __future__ import annotations

import atexit
import contextlib
import glob
import os
import sys
import weakref
from collections.abc import Iterator, Mapping

from .base import SolverError

#: The objects holding PETSc objects (each with ``destroy()``), destroyed at exit.
_LIVE: weakref.WeakSet = weakref.WeakSet()
_started = False

#: Where Debian's complex petsc4py and slepc4py are (glob patterns; the real ones are on the venv's path).
COMPLEX_PATHS = ("/usr/lib/petscdir/*/*-complex/lib/python3/dist-packages",
                 "/usr/lib/slepcdir/*/*-complex/lib/python3/dist-packages")
SCALARS = ("real", "complex")
#: How to get the complex build, for messages.
COMPLEX_PACKAGES = "python3-petsc4py-complex python3-slepc4py-complex ('make install' on Debian or Ubuntu)"

#: The build this process uses: chosen by `use` (default real).
_chosen = "real"


def loaded() -> str | None:
    """The scalar type of the petsc4py this process has imported ("real" or "complex"), None before any."""
    import numpy as np

    module = sys.modules.get("petsc4py.PETSc")
    if module is None:
        return None
    return "complex" if np.issubdtype(module.ScalarType, np.complexfloating) else "real"


def use(scalar: str) -> None:
    """Choose this process's build, "real" or "complex", when a command starts (before petsc4py is imported):
    "complex" puts Debian's complex petsc4py and slepc4py first on ``sys.path``. A `SolverError` (one line) if the
    other build is already imported, or the complex one is not installed."""
    global _chosen
    if scalar not in SCALARS:
        raise ValueError(f"scalar: expected one of {', '.join(SCALARS)}, got {scalar!r}")
    if (current := loaded()) not in (None, scalar):
        raise SolverError(f"solver: this process has PETSc with {current} scalars; {scalar} ones need a process "
                          "of their own (one PETSc build per process)")
    if scalar == "complex" and current is None:
        found = [sorted(glob.glob(pattern)) for pattern in COMPLEX_PATHS]
        if not all(found):
            raise SolverError(f"solver: PETSc and SLEPc with complex scalars are not installed: {COMPLEX_PACKAGES}")
        for name in ("PETSC_DIR", "PETSC_ARCH", "SLEPC_DIR"):   # petsc4py's loader follows them
            if "complex" not in os.environ.get(name, "complex"):
                raise SolverError(f"solver: {name}={os.environ[name]} points at a real PETSc build; unset it for "
                                  "complex scalars")
        for paths in reversed(found):
            sys.path.insert(0, paths[-1])
    _chosen = scalar


def available() -> str | None:
    """None if petsc4py (of the chosen build, `use`) imports here, else why not (one line)."""
    if (current := loaded()) not in (None, _chosen):
        return f"this process has PETSc with {current} scalars, not {_chosen} ones"
    try:
        from petsc4py import PETSc  # noqa: F401
    except ImportError as error:
        return (f"petsc4py does not import ({error}): on Debian or Ubuntu 'make install' installs it "
                "(python3-petsc4py-real); elsewhere 'conda install -c conda-forge petsc4py'")
    return None


def petsc(scalar: str = "real"):
    """The ``PETSc`` module with ``scalar`` scalars, initialised (once per process); `SolverError` if petsc4py is
    unavailable or the process has the other build (`use`)."""
    global _started
    if scalar != _chosen and loaded() is None:
        use(scalar)
    if reason := available():
        raise SolverError(f"solver: PETSc is unavailable: {reason}")
    if loaded() != scalar:
        raise SolverError(f"solver: this process has PETSc with {loaded()} scalars; expected {scalar} ones "
                          "(one PETSc build per process)")
    import petsc4py

    if not _started:
        petsc4py.init()
        atexit.register(lambda: [holder.destroy() for holder in list(_LIVE)])
        _started = True
    from petsc4py import PETSc

    return PETSc


def slepc(scalar: str = "complex"):
    """``(PETSc, SLEPc)`` with ``scalar`` scalars, initialised (`petsc`); `SolverError` if slepc4py does not
    import."""
    PETSc = petsc(scalar)
    try:
        import slepc4py
    except ImportError as error:
        raise SolverError(f"solver: SLEPc is unavailable: slepc4py does not import ({error}); on Debian or Ubuntu "
                          "'make install' installs it") from None
    slepc4py.init()
    from slepc4py import SLEPc

    return PETSc, SLEPc


def option_names(options: Mapping[str, object], prefix: str) -> dict[str, object]:
    """``options`` keyed by their names without the leading dash and ``prefix``."""
    return {str(key).lstrip("-").removeprefix(prefix): value for key, value in options.items()}


@contextlib.contextmanager
def entered_options(PETSc, prefix: str, defaults: Mapping[str, object],
                    options: Mapping[str, object]) -> Iterator[dict[str, str]]:
    """Within: ``defaults``, then ``options`` (the case file's or the command line's) in PETSc's options database
    under ``prefix`` (keys without it; True: an option without a value), what the user set there already
    (PETSC_OPTIONS) kept; yields the options in force. After: the entries made here taken out again (the database
    is one per process: the next solver starts from PETSC_OPTIONS and its own options only)."""
    database = PETSc.Options()
    given = option_names(options, prefix)
    entered = []
    for key, value in {**defaults, **given}.items():
        if key in given or not database.hasName(prefix + key):
            database[prefix + key] = "" if value is True else str(value)
            entered.append(prefix + key)
    try:
        yield {key: database.getString(prefix + key, "") for key in {**defaults, **given}}
    finally:
        for name in entered:
            database.delValue(name)


def register(holder) -> None:
    """Destroy ``holder`` (``holder.destroy()``) at exit, before PETSc finalises, unless it was destroyed before."""
    _LIVE.add(holder)


def unregister(holder) -> None:
    """``holder`` destroyed its PETSc objects itself."""
    _LIVE.discard(holder)
