"""Stopping a run by SIGINT or SIGTERM (`STOP_SIGNALS`): during set-up at once (`raise_terminated`), in the time
loop after the current step and its checkpoint (`Interrupt`); either way a `Terminated`. A signal the process was
started ignoring stays ignored (`catch`)."""
from __future__ import annotations

import signal


class Terminated(KeyboardInterrupt):
    """The run was stopped by ``signal`` (SIGINT: Ctrl-C, SIGTERM: a scheduler's time limit, ``timeout``):
    ``step`` and ``time`` where it stopped, ``checkpoint`` the file written there (None: during set-up)."""

    def __init__(self, signum: int, step: int | None = None, time: float | None = None, checkpoint=None):
        super().__init__(signal.Signals(signum).name)
        self.signum, self.step, self.time, self.checkpoint = signum, step, time, checkpoint

    @property
    def exit_code(self) -> int:
        return 128 + self.signum

    def message(self) -> str:
        if self.step is None:
            return f"{'interrupted' if self.signum == signal.SIGINT else 'terminated'} during set-up: nothing written"
        what = "interrupted" if self.signum == signal.SIGINT else "terminated"
        return f"{what} at step {self.step} (t = {self.time:g}): checkpoint {self.checkpoint}; continue with --resume"


def raise_terminated(signum, _frame) -> None:
    """A signal handler for set-up: stop at once."""
    raise Terminated(signum)


#: The signals that stop a run: during set-up at once (`raise_terminated`), in the loop after the step (`Interrupt`).
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def catch(handler) -> dict:
    """``handler`` for each of `STOP_SIGNALS` not ignored now; the handlers it replaced, to restore. An ignored
    signal stays ignored, as POSIX intends: a shell without job control starts a background job (``fsivsp run … &``
    in a script) with SIGINT ignored, so that the script's Ctrl-C leaves it running, as it leaves ``fsivsp study``."""
    return {signum: signal.signal(signum, handler) for signum in STOP_SIGNALS
            if signal.getsignal(signum) is not signal.SIG_IGN}


class Interrupt:
    """SIGINT and SIGTERM set a flag; the time loop finishes the current step, checkpoints and stops."""

    def __init__(self):
        self.requested = 0

    def __enter__(self):
        self._previous = catch(self._handle)
        return self

    def _handle(self, signum, _frame):
        self.requested = signum

    def __exit__(self, *exc):
        for signum, previous in self._previous.items():
            signal.signal(signum, previous)
