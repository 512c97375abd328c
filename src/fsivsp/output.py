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

import errno
import json
import math
import os
import shutil
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import ngsolve as ngs

from . import atomic, parallel
from .case import CaseError
from .geometry import FLUID, SOLID
from .threads import sequential

#: ``region`` values in the VTU files (point and cell data, for ParaView's Threshold)
REGIONS = {FLUID: 0, SOLID: 1}

# -- VTK --------------------------------------------------------------------------------


def _components(tensor: ngs.CoefficientFunction, dim: int) -> ngs.CoefficientFunction:
    """A d×d matrix as the row-major vector (σ_11, σ_12, …, σ_dd)."""
    return ngs.CF(tuple(tensor[i, j] for i in range(dim) for j in range(dim)))


#: ParaView's symmetric-tensor order XX, YY, ZZ, XY, YZ, XZ as (row, column) pairs
SYMMETRIC = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))


def symmetric_tensor(tensor: ngs.CoefficientFunction, dim: int) -> ngs.CoefficientFunction:
    """A symmetric d×d matrix as ParaView's 6-component tensor (XX, YY, ZZ, XY, YZ, XZ); in 2D the
    z components are 0 (the in-plane stress)."""
    return ngs.CF(tuple(tensor[i, j] if i < dim and j < dim else 0 for i, j in SYMMETRIC))


class SolidStress:
    """σ_h copied into a plain (L²)^{d·d} GridFunction of the same order on Ω_S (exact: the same
    polynomials per component). VTKOutput evaluates the symmetric matrix-valued space through a
    generic fallback that prints "called base class apply" at every point; this copy does not."""

    def __init__(self, scheme):
        mesh, self.scheme, self.dim = scheme.spaces.mesh, scheme, scheme.spaces.mesh.dim
        order = scheme.spaces.stress.globalorder
        with sequential():
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
    ``stress`` (the solid stress σ as ParaView's symmetric tensor XX YY ZZ XY YZ XZ, 0 in the fluid),
    ``von_mises`` (see `von_mises`, 0 in the fluid), ``displacement`` (the solid displacement, d components,
    0 in the fluid: the scheme's integrated velocity there is no displacement) and ``region`` (0 fluid, 1 solid).
    """
    mesh = scheme.spaces.mesh
    dim = mesh.dim
    stress = SolidStress(scheme)
    sigma = ngs.CF(stress.values, dims=(dim, dim))
    fields = {
        "velocity": scheme.velocity,
        "pressure": scheme.pressure,
        "stress": symmetric_tensor(sigma, dim),
        "von_mises": von_mises(sigma, scheme.materials, dim),
        "displacement": mesh.MaterialCF({SOLID: 1}, default=0) * scheme.displacement,
        "region": region_cf(mesh),
    }
    return fields, stress


def region_cf(mesh: ngs.Mesh) -> ngs.CoefficientFunction:
    """0 in the fluid, 1 in the solid (`REGIONS`)."""
    return mesh.MaterialCF(dict(REGIONS), default=-1)


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
                 name: str = "fields", subdivision: int = 0, refresh=None, continuous: bool = False):
        """``refresh``, if given, is called before every write (see `SolidStress`); ``continuous``: one point
        per mesh vertex instead of VTKOutput's copy per cell (see `postprocess`)."""
        if not fields:
            raise ValueError("fields: expected at least one field to write")
        self.directory, self.mesh, self.name = Path(directory), mesh, name
        self.fields, self.subdivision, self.refresh = dict(fields), subdivision, refresh
        self.continuous = continuous
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
        with atomic.replacing(final) as tmp:
            self._vtk(tmp)
        self._add(time, [final.name])
        return final

    def _vtk(self, path: Path) -> None:
        """VTKOutput into ``path`` (it appends ``.vtu``; moved back to ``path``), then `postprocess`."""
        written = path.with_name(path.name + ".vtu")
        try:
            ngs.VTKOutput(self.mesh, coefs=list(self.fields.values()), names=list(self.fields),
                          filename=str(path), subdivision=self.subdivision).Do()
            if not written.is_file():
                raise RuntimeError(f"VTKOutput did not write {written.name}")
            os.replace(written, path)
        finally:
            written.unlink(missing_ok=True)
        self._finish(path)

    def _finish(self, path: Path) -> None:
        """A file NGSolve's VTKOutput wrote, post-processed (`postprocess`) or at least read back whole; it does
        not report a failed write (a full disk leaves an incomplete file): an OSError saying why."""
        import meshio

        try:
            postprocess(path, self.continuous) if "region" in self.fields else meshio.read(path, file_format="vtu")
        except (ValueError, SyntaxError, KeyError, IndexError) as error:  # an ElementTree ParseError is a SyntaxError
            raise _incomplete(path.parent) from error

    def _add(self, time: float, names: list[str]) -> None:
        """Enter the files of ``time`` into the collection (rank 0 writes it)."""
        entries = [(t, n) for t, n in self._entries if n not in names and t < time] + [(float(time), n) for n in names]
        if parallel.is_root():
            atomic.write_text(self.pvd, _pvd(entries))
        self._entries = entries

    def _write_pieces(self, time: float, step: int) -> Path:
        """Under MPI: NGSolve writes rank r's part of the mesh (rank 0 has none) under a temporary name, which
        rank r checks (and post-processes) and moves to ``{name}_{step:06d}_proc{r}.vtu`` atomically. A piece that
        fails (NGSolve's writer does not report a full disk: its file is then incomplete) raises `WriteError` on
        every rank, naming the first failed piece."""
        base = self.directory / self.filename(step).removesuffix(".vtu")
        scratch = self.directory / f".{base.name}.part"
        ngs.VTKOutput(self.mesh, coefs=list(self.fields.values()), names=list(self.fields), filename=str(scratch),
                      subdivision=self.subdivision).Do()
        failed = None
        if parallel.is_root():
            scratch.with_suffix(".pvd").unlink(missing_ok=True)
        else:
            written = scratch.with_name(f"{scratch.name}_proc{parallel.rank()}.vtu")
            piece = base.with_name(f"{base.name}_proc{parallel.rank()}.vtu")
            try:
                self._move_piece(written, piece)
            except atomic.WriteError as error:
                failed = (str(error.path), error.errno, error.reason)
        first = next((f for f in parallel.gather(failed) if f), None)
        if first:
            raise atomic.WriteError(Path(first[0]), OSError(first[1], first[2]))
        names = [f"{base.name}_proc{r}.vtu" for r in range(1, parallel.size())]
        self._add(time, names)
        return self.directory / names[0]

    def _move_piece(self, written: Path, piece: Path) -> None:
        """``written`` (NGSolve's file) to ``piece`` atomically, `_finish`-ed."""
        try:
            with atomic.replacing(piece) as tmp:
                os.replace(written, tmp)
                self._finish(tmp)
        finally:
            written.unlink(missing_ok=True)


def _incomplete(folder: Path) -> OSError:
    """Why a file written by NGSolve does not read back: a full disk where ``folder`` has (almost) no space left."""
    if shutil.disk_usage(folder).free < 1 << 16:
        return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    return OSError(errno.EIO, "NGSolve's VTKOutput wrote an incomplete file")


def postprocess(path: Path, continuous: bool = False) -> None:
    """Rewrite a VTKOutput file (point data per cell copy, with a ``region`` field) with meshio: ``region`` also as
    cell data; with ``continuous``, the points merged to one per location, each field's value there the mean over
    the copies in the cells where the field lives (pressure: fluid; stress, von_mises, displacement: solid)."""
    import meshio

    data = meshio.read(path, file_format="vtu")
    cells = data.cells[0].data
    point_region = np.asarray(data.point_data["region"]).reshape(-1)
    cell_region = point_region[cells[:, 0]].astype(np.int32)
    points, point_data = data.points, dict(data.point_data)
    if continuous:
        points, cells, point_data = _merge(points, cells, point_data, cell_region)
    meshio.write(path, meshio.Mesh(points, [(data.cells[0].type, cells)], point_data=point_data,
                                   cell_data={"region": [cell_region]}), file_format="vtu")


#: the region a field lives in (its value at an interface point comes from there); others: every cell
HOME = {"pressure": REGIONS[FLUID], "stress": REGIONS[SOLID], "von_mises": REGIONS[SOLID],
        "displacement": REGIONS[SOLID]}


def _merge(points, cells, point_data, cell_region):
    scale = max(float(np.ptp(points, axis=0).max()), 1.0)
    keys = np.round(points / scale * 1e9).astype(np.int64)
    unique, first, index = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    index = index.reshape(-1)
    copy_region = np.empty(len(points), dtype=np.int32)
    copy_region[cells.reshape(-1)] = np.repeat(cell_region, cells.shape[1])
    merged = {}
    for name, values in point_data.items():
        values = np.asarray(values, dtype=float)
        flat = values.reshape(len(points), -1)
        home = HOME.get(name)
        weight = np.ones(len(points)) if home is None else (copy_region == home).astype(float)
        total = np.zeros((len(unique), flat.shape[1]))
        np.add.at(total, index, flat * weight[:, None])
        count = np.zeros(len(unique))
        np.add.at(count, index, weight)
        mean = total / np.maximum(count, 1)[:, None]
        merged[name] = mean.reshape((len(unique),) + values.shape[1:])
    merged["region"] = np.asarray(merged["region"]).round()
    return points[first], index[cells], merged


# -- probes ---------------------------------------------------------------------------


def bounding_box(mesh: ngs.Mesh) -> str:
    """The (global, under MPI) bounding box of the mesh's vertices, e.g. ``[0, 2.5] × [0, 0.41]``."""
    points = np.array([v.point for v in mesh.vertices], dtype=float).reshape(-1, mesh.dim)
    low = np.min(np.array(parallel.gather(points.min(axis=0) if len(points) else np.full(mesh.dim, np.inf))), axis=0)
    high = np.max(np.array(parallel.gather(points.max(axis=0) if len(points) else np.full(mesh.dim, -np.inf))), axis=0)
    size = max(b - a for a, b in zip(low, high))
    tidy = lambda x: 0.0 if abs(x) < 1e-12 * size else x  # noqa: E731 (round-off of a vertex at 0)
    return " × ".join(f"[{tidy(a):g}, {tidy(b):g}]" for a, b in zip(low, high))


def _fluid_side(mesh: ngs.Mesh, coords: np.ndarray) -> np.ndarray:
    """``coords`` with every point that the mesh search puts in a solid cell but that lies on a fluid cell's
    boundary (a point on Γ) moved by 1e-9 of the mesh's size into that fluid cell, where the pressure lives."""
    located = mesh(*(coords[:, k] for k in range(coords.shape[1])))
    solid = [i for i, nr in enumerate(located["nr"]) if nr >= 0 and mesh[ngs.ElementId(ngs.VOL, int(nr))].mat != FLUID]
    if not solid:
        return coords
    points = np.array([v.point for v in mesh.vertices], dtype=float)
    step = 1e-9 * max(float(np.ptp(points, axis=0).max()), 1.0)
    coords = coords.copy()
    directions = [np.array(c, float) - 1 for c in np.ndindex(*(3,) * coords.shape[1]) if any(np.array(c) != 1)]
    for i in solid:
        for d in directions:
            trial = coords[i] + step * d
            found = mesh(*trial)
            if found.nr >= 0 and mesh[ngs.ElementId(ngs.VOL, found.nr)].mat == FLUID:
                coords[i] = trial
                break
    return coords


class Probes:
    """Velocity and pressure at points, and along straight lines, over time.

    ``points``: coordinates (x, y[, z]); ``lines``: (start, end, n) with n ≥ 2 equispaced
    samples from start to end inclusive. Every point must lie in the mesh (`CaseError`, one line with the
    mesh's bounding box, otherwise). The pressure is NaN at points in the solid; a point on Γ is evaluated
    from the fluid side.
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
        has) with their mask among all points, and whether each is in a fluid cell. A point outside the mesh is a
        one-line `CaseError` with the mesh's bounding box; a point on Γ is evaluated in a fluid cell (`_fluid_side`)."""
        if not len(coords):
            return (None, np.zeros(0, dtype=bool)), np.zeros(0, dtype=bool)
        coords = _fluid_side(mesh, coords)
        located = mesh(*(coords[:, k] for k in range(coords.shape[1])))
        owner = parallel.owners(located["nr"] >= 0)
        outside = np.flatnonzero(owner < 0)
        if len(outside):
            i = int(outside[0])
            where = ", ".join(f"{c:g}" for c in coords[i])
            raise CaseError(f"{label.format(i)} at ({where}) is outside the mesh; expected a point in its "
                            f"bounding box {bounding_box(mesh)}")
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
            atomic.write_text(path, _csv(columns, rows))
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


def write_summary(path: str | Path, data: dict) -> None:
    """A JSON summary of a run (atomic, with the umask's modes)."""
    atomic.write_text(path, json.dumps(data, indent=2) + "\n")
