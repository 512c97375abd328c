"""Progress bars that suit both a terminal and a log file.

`tqdm` is tqdm's bar (``tqdm.auto``) when stderr is a terminal (or in a notebook); when stderr is redirected to a
file or a pipe it is a `LogBar`, which writes a plain line now and then instead of redrawing a bar with
carriage returns and escape codes (a log of ``fsivsp run ... 2> log`` then reads, e.g.,

    tube: 120/400 steps (30%), 61 s, pardiso, 0.21 GiB
"""
from __future__ import annotations

import sys
import time

#: seconds between two lines of a `LogBar`
INTERVAL = 30.0


def tqdm(iterable=None, **options):
    """``tqdm.auto.tqdm(iterable, **options)`` on a terminal, a `LogBar` elsewhere."""
    if options.get("disable") or sys.stderr.isatty() or "ipykernel" in sys.modules:
        from tqdm.auto import tqdm as bar

        return bar(iterable, **options)
    return LogBar(iterable, **options)


class LogBar:
    """The part of tqdm's interface fsivsp uses (iteration, ``with``, ``update``, ``set_postfix_str``): a line
    ``DESC: N/TOTAL UNITs (P%), T s[, POSTFIX]`` on stderr at most every `INTERVAL` seconds, and at the end
    (not with ``leave=False``: an inner bar)."""

    def __init__(self, iterable=None, total=None, initial=0, desc=None, unit="it", leave=True, **_options):
        if total is None and hasattr(iterable, "__len__"):
            total = len(iterable)
        self.iterable, self.total, self.n = iterable, total, initial
        self.desc, self.unit, self.leave = desc, unit, leave
        self.postfix, self.closed = "", False
        self.start = self.last = time.monotonic()

    def __iter__(self):
        for item in self.iterable:
            yield item
            self.update(1)
        self.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def update(self, n: int = 1) -> None:
        self.n += n
        if time.monotonic() - self.last >= INTERVAL:
            self._line()

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None:
        self.postfix = s

    def close(self) -> None:
        if not self.closed and self.leave:
            self._line()
        self.closed = True

    def _line(self) -> None:
        self.last = time.monotonic()
        count = f"{self.n}/{self.total}" if self.total else f"{self.n}"
        percent = f" ({100 * self.n / self.total:.0f}%)" if self.total else ""
        plural = "s" * ((self.total or self.n) != 1)
        parts = [f"{count} {self.unit}{plural}{percent}", f"{self.last - self.start:.0f} s"]
        text = ", ".join(parts + ([self.postfix] if self.postfix else []))
        print(f"{self.desc}: {text}" if self.desc else text, file=sys.stderr, flush=True)
