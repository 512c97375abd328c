"""Output of production runs: VTK time series with a ParaView collection, point and
line probes written as CSV, energy and probe plots, and a JSON summary.

Every file is written next to its final name and moved into place with
``os.replace``, so an interrupted run never leaves a half-written file where a
good one was (the VTK series, the ``.pvd`` collection, the CSV files, the plots).

    fields, stress = scheme_fields(scheme)
    series = VTKSeries(out, scheme.spaces.mesh, fields, refresh=stress)
    probes = Probes(scheme.spaces.mesh, points=[(0.2, 0.2)], lines=[((0, 0.2), (2.5, 0.2), 50)])
    for _ in range(steps):
        scheme.step()
        probes.record(scheme)
        series.write(scheme.time, scheme.n)
    probes.write_csv(out)
"""
from __future__ import annotations

import math
import os
import tempfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import ngsolve as ngs

from . import parallel
from .geometry import FLUID
from .report import write_atomic, write_json

# -- VTK --------------------------------------------------------------------------------


def _components(tensor: ngs.CoefficientFunction, dim: int) -> ngs.CoefficientFunction:
    """A d×d matrix as the row-major vector (σ_11, σ_12, …, σ_dd)."""
    return ngs.CF(tuple(tensor[i, j] for i in range(dim) for j in range(dim)))


class SolidStress:
    """σ_h copied into a plain (L²)^{d·d} GridFunction of the same order on Ω_S (exact: the same
    polynomials per component). VTKOutput evaluates the symmetric matrix-valued space through a
    generic fallback that prints "called base class apply" at every point; this copy does not."""

    def __init__(self, scheme):
        mesh, self.scheme, self.dim = scheme.spaces.mesh, scheme, scheme.spaces.mesh.dim
        order = scheme.spaces.stress.globalorder
        self.values = ngs.GridFunction(ngs.L2(mesh, order=order, definedon=mesh.Materials("solid")) ** (self.dim ** 2))

    def __call__(self) -> None:
        self.values.Set(_components(self.scheme.stress, self.dim))


def von_mises(stress: ngs.CoefficientFunction, materials, dim: int) -> ngs.CoefficientFunction:
    """sqrt(3/2 s:s) with s the deviatoric part of the (3D) stress.

    In 2D the stress is completed to 3D by plane strain (ε_zz = 0, so
    σ_zz = λ tr ε = λ/(2(λ+μ)) (σ_xx + σ_yy), σ_xz = σ_yz = 0); then
    s:s = σ:σ + σ_zz² − (tr σ + σ_zz)²/3.
    """
    contraction = ngs.InnerProduct(stress, stress)
    trace = ngs.Trace(stress)
    if dim == 2:
        zz = materials.lam / (2 * (materials.lam + materials.mu)) * trace
        contraction = contraction + zz * zz
        trace = trace + zz
    deviatoric = contraction - trace * trace / 3
    return ngs.sqrt(1.5 * ngs.IfPos(deviatoric, deviatoric, 0))


def scheme_fields(scheme) -> tuple[dict[str, ngs.CoefficientFunction], SolidStress]:
    """The fields of a `Scheme` for `VTKSeries`, and the `SolidStress` to refresh before writing.

    ``velocity`` (d components), ``pressure`` (the fluid pressure, 0 in the solid),
    ``stress`` (the solid stress σ as d·d row-major components, 0 in the fluid),
    ``von_mises`` (see `von_mises`, 0 in the fluid) and ``displacement`` (d components, 0 in the fluid).
    """
    dim = scheme.spaces.mesh.dim
    stress = SolidStress(scheme)
    fields = {
        "velocity": scheme.velocity,
        "pressure": scheme.pressure,
        "stress": stress.values,
        "von_mises": von_mises(ngs.CF(stress.values, dims=(dim, dim)), scheme.materials, dim),
        "displacement": scheme.displacement,
    }
    return fields, stress


def _pvd(entries: list[tuple[float, str]]) -> str:
    """The collection; files of the same time are its parts 0, 1, … (the pieces of a distributed run)."""
    lines = ['<?xml version="1.0"?>',
             '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
             "  <Collection>"]
    parts: dict[float, int] = {}
    for time, name in entries:
        parts[time] = parts.get(time, -1) + 1
        lines.append(f'    <DataSet timestep="{time!r}" group="" part="{parts[time]}" file={quoteattr(name)}/>')
    lines += ["  </Collection>", "</VTKFile>", ""]
    return "\n".join(lines)


class VTKSeries:
    """``{name}_{step:06d}.vtu`` files and the ParaView collection ``{name}.pvd``.

    Each step is written by `ngsolve.VTKOutput` under a hidden temporary name in the same
    directory and renamed into place; the ``.pvd`` (all files written so far, with their
    times) is then rewritten atomically. A write drops the entries of the same file and
    of later times, so a run resumed from a checkpoint replaces the steps after it.
    """

    def __init__(self, directory: str | Path, mesh: ngs.Mesh, fields: dict[str, ngs.CoefficientFunction],
                 name: str = "fields", subdivision: int = 0, refresh=None):
        """``refresh``, if given, is called before every write (see `SolidStress`)."""
        if not fields:
            raise ValueError("fields: expected at least one field to write")
        self.directory, self.mesh, self.name = Path(directory), mesh, name
        self.fields, self.subdivision, self.refresh = dict(fields), subdivision, refresh
        self._entries: list[tuple[float, str]] = []

    @property
    def pvd(self) -> Path:
        return self.directory / f"{self.name}.pvd"

    @property
    def entries(self) -> list[tuple[float, str]]:
        """(time, file name relative to the directory) of every file written, in order."""
        return list(self._entries)

    def restore(self, entries) -> None:
        """Continue the collection of an earlier run (``entries`` as from `entries`, e.g.
        from a checkpoint's JSON, where the pairs have become lists)."""
        self._entries = [(float(time), str(name)) for time, name in entries]

    def filename(self, step: int) -> str:
        return f"{self.name}_{step:06d}.vtu"

    def write(self, time: float, step: int) -> Path:
        """Write the fields at ``time`` as step ``step``; returns the file's path."""
        if self.refresh is not None:
            self.refresh()
        self.directory.mkdir(parents=True, exist_ok=True)
        if parallel.distributed():
            return self._write_pieces(time, step)
        final = self.directory / self.filename(step)
        fd, reserved = tempfile.mkstemp(dir=self.directory, prefix=f".{final.stem}.", suffix=".tmp")
        os.close(fd)
        base = Path(reserved)
        written = base.with_name(base.name + ".vtu")  # VTKOutput appends the extension
        try:
            output = ngs.VTKOutput(self.mesh, coefs=list(self.fields.values()), names=list(self.fields),
                                   filename=str(base), subdivision=self.subdivision)
            output.Do()
            if not written.is_file():
                raise RuntimeError(f"VTKOutput did not write {written.name}")
            os.replace(written, final)
        finally:
            written.unlink(missing_ok=True)
            base.unlink(missing_ok=True)
        self._add(time, [final.name])
        return final

    def _add(self, time: float, names: list[str]) -> None:
        """Enter the files of ``time`` into the collection (rank 0 writes it)."""
        entries = [(t, n) for t, n in self._entries if n not in names and t < time] + [(float(time), n) for n in names]
        if parallel.is_root():
            write_atomic(self.pvd, _pvd(entries))
        self._entries = entries

    def _write_pieces(self, time: float, step: int) -> Path:
        """Under MPI: NGSolve writes ``{name}_{step:06d}_proc{r}.vtu``, rank r's part of the mesh (rank 0 has
        none), and the ``.pvd`` of that step, which the collection replaces (not atomic, unlike the serial files)."""
        base = self.directory / self.filename(step).removesuffix(".vtu")
        ngs.VTKOutput(self.mesh, coefs=list(self.fields.values()), names=list(self.fields), filename=str(base),
                      subdivision=self.subdivision).Do()
        if parallel.is_root():
            base.with_suffix(".pvd").unlink(missing_ok=True)
        names = [f"{base.name}_proc{r}.vtu" for r in range(1, parallel.size())]
        self._add(time, names)
        return self.directory / names[0]


# -- probes ---------------------------------------------------------------------------


class Probes:
    """Velocity and pressure at points, and along straight lines, over time.

    ``points``: coordinates (x, y[, z]); ``lines``: (start, end, n) with n ≥ 2 equispaced
    samples from start to end inclusive. Every point must lie in the mesh (ValueError
    otherwise). The pressure is NaN at points whose containing cell is not a fluid cell
    (a point on Γ counts as fluid only if the mesh search returns a fluid cell).
    """

    def __init__(self, mesh: ngs.Mesh, points=(), lines=()):
        self.dim = mesh.dim
        self.points = np.array([self._coords(p, f"probe {i}") for i, p in enumerate(points)],
                               dtype=float).reshape(-1, self.dim)
        self.lines = []
        for i, line in enumerate(lines):
            try:
                start, end, n = line
            except (TypeError, ValueError):
                raise ValueError(f"line {i}: expected (start, end, n), got {line!r}") from None
            start, end = self._coords(start, f"line {i} start"), self._coords(end, f"line {i} end")
            if int(n) != n or n < 2:
                raise ValueError(f"line {i}: expected at least 2 sample points, got {n!r}")
            self.lines.append((start, end, int(n)))
        self._point_locations, self._point_fluid = self._locate(mesh, self.points, "probe {}")
        self._line_points, self._line_s, self._line_locations, self._line_fluid = [], [], [], []
        for i, (start, end, n) in enumerate(self.lines):
            weights = np.linspace(0.0, 1.0, n)
            coords = start[None, :] + weights[:, None] * (end - start)[None, :]
            located, fluid = self._locate(mesh, coords, f"line {i} point {{}}")
            self._line_points.append(coords)
            self._line_s.append(weights * float(np.linalg.norm(end - start)))
            self._line_locations.append(located)
            self._line_fluid.append(fluid)
        self.probe_rows: list[list[float]] = []
        self.line_rows: list[list[float]] = []

    def _coords(self, point, label: str) -> np.ndarray:
        coords = np.asarray(point, dtype=float).ravel()
        if coords.shape != (self.dim,) or not np.all(np.isfinite(coords)):
            raise ValueError(f"{label}: expected {self.dim} finite coordinates, got {point!r}")
        return coords

    @staticmethod
    def _locate(mesh: ngs.Mesh, coords: np.ndarray, label: str):
        """The points this process evaluates (on a distributed mesh, MPI: those of its part that no lower rank
        has) with their mask among all points, and whether each is in a fluid cell."""
        if not len(coords):
            return (None, np.zeros(0, dtype=bool)), np.zeros(0, dtype=bool)
        located = mesh(*(coords[:, k] for k in range(coords.shape[1])))
        owner = parallel.owners(located["nr"] >= 0)
        outside = np.flatnonzero(owner < 0)
        if len(outside):
            i = int(outside[0])
            where = ", ".join(f"{c:g}" for c in coords[i])
            raise ValueError(f"{label.format(i)} at ({where}) is outside the mesh")
        mine = owner == parallel.rank()
        fluid = np.array([mesh[ngs.ElementId(ngs.VOL, int(nr))].mat == FLUID for nr in located["nr"][mine]])
        return (located[mine], mine), fluid

    def _evaluate(self, scheme, located, fluid) -> tuple[np.ndarray, np.ndarray]:
        (points, mine), n = located, len(located[1])
        values = np.zeros((n, self.dim + 1))
        if mine.any():
            values[mine, :self.dim] = np.asarray(scheme.velocity(points)).reshape(-1, self.dim)
            pressure = np.asarray(scheme.pressure(points), dtype=float).reshape(-1)
            values[mine, self.dim] = np.where(fluid, pressure, np.nan)
        values = parallel.total(values)  # each point's values come from one rank
        return values[:, :self.dim], values[:, self.dim]

    def record(self, scheme) -> None:
        """Append the values of the scheme's current state (step ``scheme.n``)."""
        step, time = int(scheme.n), float(scheme.time)
        row = [step, time]
        if len(self.points):
            velocity, pressure = self._evaluate(scheme, self._point_locations, self._point_fluid)
            for v, p in zip(velocity, pressure):
                row += [float(c) for c in v] + [float(p)]
        self.probe_rows.append(row)
        for i, (coords, s, located, fluid) in enumerate(zip(self._line_points, self._line_s,
                                                            self._line_locations, self._line_fluid)):
            velocity, pressure = self._evaluate(scheme, located, fluid)
            for k in range(len(s)):
                self.line_rows.append([step, time, i, float(s[k])] + [float(c) for c in coords[k]]
                                      + [float(c) for c in velocity[k]] + [float(pressure[k])])

    # -- tables -------------------------------------------------------------------
    @property
    def probe_columns(self) -> list[str]:
        names = [f"v{k + 1}" for k in range(self.dim)] + ["p"]
        return ["step", "time"] + [f"p{i}_{n}" for i in range(len(self.points)) for n in names]

    @property
    def line_columns(self) -> list[str]:
        return (["step", "time", "line", "s"] + list("xyz"[: self.dim])
                + [f"v{k + 1}" for k in range(self.dim)] + ["p"])

    def series(self, probe: int) -> dict[str, np.ndarray]:
        """Time series of one point probe: ``time``, ``v1``…, ``p``."""
        if not 0 <= probe < len(self.points):
            raise ValueError(f"probe: expected an index below {len(self.points)}, got {probe}")
        table = np.array(self.probe_rows, dtype=float).reshape(-1, len(self.probe_columns))
        width = self.dim + 1
        out = {"step": table[:, 0], "time": table[:, 1]}
        for k, name in enumerate([f"v{j + 1}" for j in range(self.dim)] + ["p"]):
            out[name] = table[:, 2 + probe * width + k]
        return out

    def write_csv(self, directory: str | Path) -> tuple[Path, Path]:
        """``probes.csv`` and ``lines.csv`` in ``directory``, each written atomically."""
        directory = Path(directory)
        paths = directory / "probes.csv", directory / "lines.csv"
        for path, columns, rows in zip(paths, (self.probe_columns, self.line_columns),
                                       (self.probe_rows, self.line_rows)):
            write_atomic(path, _csv(columns, rows))
        return paths

    # -- checkpoints --------------------------------------------------------------
    def state(self) -> dict:
        """The history as plain, strictly JSON-serialisable lists (NaN as None)."""
        plain = lambda rows: [[None if isinstance(c, float) and math.isnan(c) else c for c in r] for r in rows]
        return {"probe_rows": plain(self.probe_rows), "line_rows": plain(self.line_rows)}

    def restore(self, state: dict) -> None:
        """Continue the history saved by `state`."""
        def rows(values, width):
            out = []
            for r in values:
                if len(r) != width:
                    raise ValueError(f"probes: a saved row has {len(r)} values, expected {width} "
                                     "(were the probes defined differently?)")
                out.append([int(r[0]), float(r[1])] + [float("nan") if c is None else c for c in r[2:]])
            return out

        self.probe_rows = rows(state.get("probe_rows", []), len(self.probe_columns))
        self.line_rows = rows(state.get("line_rows", []), len(self.line_columns))
        for r in self.line_rows:
            r[2] = int(r[2])


def _cell(value) -> str:
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return repr(float(value))


def _csv(columns: list[str], rows) -> str:
    lines = [",".join(columns)] + [",".join(_cell(c) for c in row) for row in rows]
    return "\n".join(lines) + "\n"


# -- plots and summary ----------------------------------------------------------------


def _save(fig, path: str | Path) -> None:
    """Save a figure through a temporary file in the same directory and close it."""
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fmt = path.suffix[1:].lower() or "png"
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            fig.savefig(handle, format=fmt, dpi=120)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
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
    ax.set_xlabel("time")
    ax.set_ylabel("energy")
    ax.grid(True, alpha=0.3)
    _save(fig, path)


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
        ax.set_title(name)
        ax.set_xlabel("time")
        ax.grid(True, alpha=0.3)
    if len(probes.points):
        axes[0].legend(fontsize=7)
    _save(fig, path)


def write_summary(path: str | Path, data: dict) -> None:
    """A JSON summary of a run (atomic, via `report.write_json`)."""
    write_json(path, data)
