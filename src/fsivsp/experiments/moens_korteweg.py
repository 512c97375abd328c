"""Physical validation: the speed of a pressure pulse in an elastic tube (issue 4).

A pressure pulse driven into a fluid-filled elastic tube travels at the Moens–Korteweg
speed (thin wall, long waves, inviscid fluid). `examples/pressure_wave.toml` is the 3D
case; this module turns its ``probes.csv`` into a measured speed:

    times = arrival_times("out/probes.csv")                # one arrival time per probe
    c = wave_speed([1, 1.5, 2, 2.5, 3, 3.5, 4], times)     # least-squares speed [cm/s]
    c / moens_korteweg(3e6, 0.1, 1.0, 0.5, 0.3)            # 0.85 for the example

(0.85 rather than 1: the example's wall is thick, h/R = 0.2, and free to contract
axially, and the pulse is dispersive; see benchmarks/pressure_wave.md.)
"""
from __future__ import annotations

import csv
import math
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

__all__ = ["moens_korteweg", "arrival_time", "arrival_times", "wave_speed", "read_probe_pressures"]


def moens_korteweg(young: float, wall: float, rho_fluid: float, radius: float, poisson: float = 0.0) -> float:
    """The Moens–Korteweg pulse wave speed c = sqrt(E h / (2 ρ_F R (1 − ν_P²))).

    ``young`` E, ``wall`` thickness h, ``rho_fluid`` ρ_F, ``radius`` R (inner radius) and
    ``poisson`` ν_P. The factor 1/(1 − ν_P²) is the wall held axially (long waves in a
    tethered tube); ν_P = 0 gives the classical E h / (2 ρ R). Thin-wall, long-wave and
    inviscid limit: it ignores the wall's inertia (dispersion as the frequency approaches
    the ring frequency sqrt(E / (ρ_S R² (1 − ν_P²)))) and its thickness (h/R finite makes
    the tube more compliant, hence slower)."""
    values = {"young": young, "wall": wall, "rho_fluid": rho_fluid, "radius": radius}
    for name, value in values.items():
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name}: expected a positive number, got {value!r}")
    if not -1 < poisson < 0.5:
        raise ValueError(f"poisson: expected a number in (-1, 0.5), got {poisson!r}")
    return math.sqrt(young * wall / (2 * rho_fluid * radius * (1 - poisson**2)))


def read_probe_pressures(probes_csv: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """``time`` (n,) and the pressure histories (n, probes) of a run's ``probes.csv``
    (columns ``step, time, p{i}_v1, …, p{i}_p``)."""
    path = Path(probes_csv)
    with path.open(newline="") as handle:
        reader = csv.reader(handle)
        header = next(reader, None)
        rows = [[float(c) for c in row] for row in reader if row]
    if header is None or "time" not in header:
        raise ValueError(f"{path}: expected a probes.csv with a 'time' column")
    pressure = {int(m.group(1)): k for k, name in enumerate(header) if (m := re.fullmatch(r"p(\d+)_p", name))}
    if not pressure:
        raise ValueError(f"{path}: no probe pressure columns (p0_p, p1_p, ...)")
    table = np.array(rows, dtype=float).reshape(-1, len(header))
    columns = [pressure[i] for i in sorted(pressure)]
    return table[:, header.index("time")], table[:, columns]


def arrival_time(time: Sequence[float], pressure: Sequence[float], fraction: float = 0.5) -> float:
    """The first time ``pressure`` reaches ``fraction`` of its maximum, linearly interpolated
    between the two samples around the crossing (see `arrival_times`)."""
    t, p = np.asarray(time, dtype=float), np.asarray(pressure, dtype=float)
    if not 0 < fraction <= 1:
        raise ValueError(f"fraction: expected a number in (0, 1], got {fraction!r}")
    if t.shape != p.shape or t.ndim != 1 or len(t) < 2:
        raise ValueError("time, pressure: expected two histories of the same length (at least 2 samples)")
    if not np.all(np.isfinite(p)):
        raise ValueError("pressure: not finite (is the probe outside the fluid?)")
    peak = p.max()
    if not peak > 0:
        raise ValueError("pressure: never positive, no pulse arrived")
    level = fraction * peak
    k = int(np.argmax(p >= level))  # the first sample at or above the level
    if k == 0:
        return float(t[0])
    return float(t[k - 1] + (level - p[k - 1]) / (p[k] - p[k - 1]) * (t[k] - t[k - 1]))


def arrival_times(probes_csv: str | Path, fraction: float = 0.5) -> list[float]:
    """The arrival time of the pulse at each probe of ``probes.csv``: the first time the probe's
    pressure reaches ``fraction`` of its maximum (default: half; linear interpolation).

    Why the leading edge at half maximum rather than the peak: the peak of a pulse near the
    traction-free outflow is pulled earlier by the inverted reflection (p = 0 there), and
    dispersion (wall inertia, backward-Euler damping) broadens the pulse and moves its peak
    about; the leading edge reaches every probe before the reflection does. Half the
    maximum stays well above the small instantaneous, non-propagating response that the
    incompressible fluid gives along the whole tube (wall inertia, decaying over a few
    tenths of a cm from the inflow) and well above noise, and a fraction of each probe's own
    maximum is insensitive to the pulse's attenuation along the tube. Sub-step resolution
    comes from the interpolation."""
    time, pressures = read_probe_pressures(probes_csv)
    return [arrival_time(time, pressures[:, i], fraction) for i in range(pressures.shape[1])]


def wave_speed(positions: Sequence[float], times: Sequence[float]) -> float:
    """The speed of a front reaching ``positions`` at ``times``: the least-squares line
    t = t₀ + x / c (the times carry the error, the positions are exact), c = 1 / slope."""
    x, t = np.asarray(positions, dtype=float), np.asarray(times, dtype=float)
    if x.shape != t.shape or x.ndim != 1 or len(x) < 2:
        raise ValueError("positions, times: expected two lists of the same length (at least 2)")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(t))):
        raise ValueError("positions, times: expected finite numbers")
    if np.ptp(x) == 0:
        raise ValueError("positions: expected at least two distinct positions")
    if np.ptp(t) == 0:
        raise ValueError("times: all equal, the speed is infinite")
    return float(1 / np.polyfit(x, t, 1)[0])
