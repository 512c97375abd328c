"""The outputs of ``fsivsp harmonic`` and ``fsivsp modes``: tables (harmonic.csv, modes.csv, overdamped.csv), their
plots, and the complex fields as VTU pairs of real and imaginary parts. Every file is written atomically (`atomic`).

A complex amplitude â of a probe is written as its amplitude |â| and its phase lag φ = −arg â in degrees, so that
the signal is |â| cos(2πft − φ), the convention of the case file's ``phase``.
"""
from __future__ import annotations

from pathlib import Path

import ngsolve as ngs
import numpy as np

from ..frequency.modes import Mode
from ..geometry import SOLID
from . import atomic
from .plots import LABELS, _pyplot, _save
from .probes import Probes, csv_text
from .quantities import region_cf, symmetric_tensor

#: The parts of a complex field in the VTU files: ``NAME_real``, ``NAME_imag``.
PARTS = ("real", "imag")


def amplitude_phase(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """|â| and the phase lag −arg â in degrees (NaN where â is)."""
    return np.abs(values), -np.degrees(np.angle(values))


def harmonic_columns(probes: Probes) -> list[str]:
    """``frequency``, then ``p{i}_{v1…, p}_amp`` and ``_phase`` for every probe (probes.csv's names)."""
    names = [f"v{k + 1}" for k in range(probes.dim)] + ["p"]
    return ["frequency"] + [f"p{i}_{name}_{part}" for i in range(len(probes.points)) for name in names
                            for part in ("amp", "phase")]


def harmonic_rows(frequencies: list[float], samples: list[np.ndarray]) -> np.ndarray:
    """One row per frequency: the frequency, then amplitude and phase of every probe's components (``samples``:
    per frequency an array probes × (d + 1), complex)."""
    rows = []
    for frequency, values in zip(frequencies, samples):
        amp, phase = amplitude_phase(values.reshape(-1))
        rows.append([frequency, *np.column_stack([amp, phase]).ravel()])
    return np.array(rows, dtype=float).reshape(len(frequencies), -1)


def write_harmonic_csv(path: str | Path, probes: Probes, frequencies: list[float], samples: list[np.ndarray]) -> None:
    """harmonic.csv (`harmonic_columns`, `harmonic_rows`)."""
    atomic.write_text(path, csv_text(harmonic_columns(probes), harmonic_rows(frequencies, samples)))


def harmonic_plot(path: str | Path, probes: Probes, frequencies: list[float], samples: list[np.ndarray]) -> None:
    """The response curves: amplitude (log scale) and phase lag (unwrapped) of every probe's components against
    frequency."""
    plt = _pyplot()
    names = [f"v{k + 1}" for k in range(probes.dim)] + ["p"]
    fig, axes = plt.subplots(2, len(names), figsize=(4 * len(names), 6), constrained_layout=True, squeeze=False)
    values = np.array(samples).reshape(len(frequencies), len(probes.points), len(names))
    amp, phase = amplitude_phase(values)
    phase = np.degrees(np.unwrap(np.radians(phase), axis=0))   # continuous through ±180°
    for i, point in enumerate(probes.points):
        label = "p{} ({})".format(i, ", ".join(f"{c:g}" for c in point))
        for j in range(len(names)):
            axes[0, j].plot(frequencies, amp[:, i, j], ".-", label=label)
            axes[1, j].plot(frequencies, phase[:, i, j], ".-", label=label)
    for j, name in enumerate(names):
        axes[0, j].set_title(LABELS[name])
        axes[0, j].set_ylabel(f"amplitude |{name}|")
        if np.nanmax(amp[..., j], initial=0) > 0:
            axes[0, j].set_yscale("log")
        axes[1, j].set_ylabel("phase lag (degrees)")
        axes[1, j].set_xlabel("frequency f")
        for ax in axes[:, j]:
            ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    fig.suptitle("harmonic response at the probes (harmonic.csv): |â| cos(2πft − φ)", fontsize=10)
    _save(fig, path)


MODE_COLUMNS = ["index", "frequency", "decay_rate", "damping_ratio", "residual", "re_s", "im_s"]


def write_modes_csv(path: str | Path, modes: list[Mode]) -> None:
    """One row per mode (`MODE_COLUMNS`), from index 1: frequency Im s/2π, decay rate −Re s, damping ratio
    −Re s/|s|, the backward error, s."""
    rows = [[i, m.frequency, m.decay_rate, m.damping_ratio, m.residual, m.s.real, m.s.imag]
            for i, m in enumerate(modes, start=1)]
    atomic.write_text(path, csv_text(MODE_COLUMNS, rows))


def modes_plot(path: str | Path, oscillating: list[Mode], overdamped: list[Mode], target: complex) -> None:
    """The eigenvalues in the complex plane (s = −decay rate + 2πi frequency) with the target."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 4.2), constrained_layout=True)
    for modes, marker, label in ((oscillating, "o", "oscillating"), (overdamped, "x", "overdamped")):
        if modes:
            ax.plot([m.s.real for m in modes], [m.s.imag for m in modes], marker, ls="none", label=label)
    for i, m in enumerate(oscillating, start=1):
        ax.annotate(str(i), (m.s.real, m.s.imag), textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax.plot([target.real], [target.imag], "+", ms=12, color="k", label="target (shift)")
    ax.set_xlabel("Re s = −decay rate")
    ax.set_ylabel("Im s = 2π frequency")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("coupled modes (modes.csv, overdamped.csv)", fontsize=9)
    _save(fig, path)


def complex_fields(velocity, pressure, displacement, stress, mesh: ngs.Mesh) -> dict[str, ngs.CoefficientFunction]:
    """The VTU fields of a complex solution: ``velocity``, ``pressure`` (fluid), ``displacement`` and ``stress``
    (the solid's; ParaView's symmetric tensor), each as ``NAME_real`` and ``NAME_imag``, and ``region``."""
    solid = mesh.MaterialCF({SOLID: 1}, default=0)
    fields = {"velocity": velocity, "pressure": pressure, "displacement": solid * displacement,
              "stress": solid * symmetric_tensor(stress, mesh.dim)}
    parts = {f"{name}_{part}": getattr(cf, part) for name, cf in fields.items() for part in PARTS}
    return {**parts, "region": region_cf(mesh)}
