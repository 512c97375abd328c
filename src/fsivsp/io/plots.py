"""The plots of a run (energy, probes, lines) and its JSON summary, written atomically."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import atomic
from .probes import Probes


def _save(fig, path: str | Path) -> None:
    """Save a figure through a temporary file in the same directory and close it."""
    import matplotlib.pyplot as plt

    path = Path(path)
    fmt = path.suffix[1:].lower() or "png"
    try:
        with atomic.replacing(path) as tmp:
            fig.savefig(tmp, format=fmt, dpi=120)
    finally:
        plt.close(fig)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def energy_plot(times, energies, path: str | Path) -> None:
    """The discrete energy ½∫ρ|v|² + ½∫_S Aσ:σ against time."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.6), constrained_layout=True)
    ax.plot(times, energies, "-", marker="." if len(times) < 60 else None)
    ax.set_xlabel("time t")
    ax.set_ylabel("E(t)")
    ax.set_title("discrete energy ½∫ρ|v|² + ½∫_S Aσ:σ (Scheme.energy)", fontsize=9)
    ax.grid(True, alpha=0.3)
    _save(fig, path)


LABELS = {"v1": "velocity v1", "v2": "velocity v2", "v3": "velocity v3", "p": "fluid pressure p"}


def probe_plot(probes: Probes, path: str | Path) -> None:
    """Velocity components and pressure of every point probe against time."""
    plt = _pyplot()
    names = [f"v{k + 1}" for k in range(probes.dim)] + ["p"]
    fig, axes = plt.subplots(1, len(names), figsize=(4 * len(names), 3.4), constrained_layout=True)
    for i in range(len(probes.points)):
        data = probes.series(i)
        label = "p{} ({})".format(i, ", ".join(f"{c:g}" for c in probes.points[i]))
        for ax, name in zip(axes, names):
            ax.plot(data["time"], data[name], label=label)
    for ax, name in zip(axes, names):
        ax.set_title(LABELS[name])
        ax.set_xlabel("time t")
        ax.set_ylabel(name)
        ax.grid(True, alpha=0.3)
    if len(probes.points):
        axes[0].legend(fontsize=7)
    fig.suptitle("point probes (probes.csv); units those of the case file", fontsize=10)
    _save(fig, path)


def line_plot(probes: Probes, path: str | Path) -> None:
    """Velocity components and pressure along every line probe at its last recorded time (lines.csv)."""
    plt = _pyplot()
    names = [f"v{k + 1}" for k in range(probes.dim)] + ["p"]
    columns = probes.line_columns
    table = np.array(probes.line_rows, dtype=float).reshape(-1, len(columns))
    fig, axes = plt.subplots(1, len(names), figsize=(4 * len(names), 3.4), constrained_layout=True)
    time = table[:, 1].max() if len(table) else 0.0
    for i, (start, end, _) in enumerate(probes.lines):
        rows = table[(table[:, 2] == i) & (table[:, 1] == time)]
        label = "line {} ({}) → ({})".format(i, ", ".join(f"{c:g}" for c in start), ", ".join(f"{c:g}" for c in end))
        for ax, name in zip(axes, names):
            ax.plot(rows[:, 3], rows[:, columns.index(name)], ".-", label=label)
    for ax, name in zip(axes, names):
        ax.set_title(LABELS[name])
        ax.set_xlabel("arc length s from the line's start")
        ax.set_ylabel(name)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"line probes at t = {time:g} (lines.csv); units those of the case file", fontsize=10)
    _save(fig, path)


def surface_plot(columns: list[str], rows: list[list[float]], path: str | Path) -> None:
    """The flow, mean pressure and force of every boundary of surfaces.csv against time."""
    plt = _pyplot()
    table = np.array(rows, dtype=float).reshape(-1, len(columns) + 1)
    panels = {"flow": "flow Q = ∫ v·n", "pressure": "mean pressure", "force": "force ∫ σn"}
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.4), constrained_layout=True)
    for ax, (key, title) in zip(axes, panels.items()):
        for k, column in enumerate(columns):
            name, quantity = column.rsplit(".", 1)
            if quantity.split("_")[0] == key and not np.all(np.isnan(table[:, k + 1])):
                ax.plot(table[:, 0], table[:, k + 1], label=column if key == "force" else name)
        ax.set_title(title)
        ax.set_xlabel("time t")
        ax.grid(True, alpha=0.3)
        if ax.lines:
            ax.legend(fontsize=7)
    fig.suptitle("surface quantities (surfaces.csv); n the outer normal of the fluid (of the solid on a solid "
                 "boundary)", fontsize=9)
    _save(fig, path)


#: A run's JSON summary: `atomic.write_json` (atomic, with the umask's modes).
write_summary = atomic.write_json
