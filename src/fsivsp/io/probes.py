"""Point and line probes of a run, recorded at every output step and written as CSV."""
from __future__ import annotations

import math
from pathlib import Path

import ngsolve as ngs
import numpy as np

from ..errors import CaseError
from ..geometry import Phases, extent
from ..runtime import parallel
from . import atomic


def bounding_box(mesh: ngs.Mesh) -> str:
    """The (global, under MPI) bounding box of the mesh's vertices, e.g. ``[0, 2.5] × [0, 0.41]``."""
    low, high = extent(mesh)
    size = max(b - a for a, b in zip(low, high))
    tidy = lambda x: 0.0 if abs(x) < 1e-12 * size else x  # noqa: E731 (round-off of a vertex at 0)
    return " × ".join(f"[{tidy(a):g}, {tidy(b):g}]" for a, b in zip(low, high))


#: How far (times the mesh's size) a point on Γ is moved into a fluid cell (`_fluid_side`): NGSolve's point search
#: counts a point within about 1e-8 of a cell as in it (a point 1e-9 above Γ was found in the solid cell below).
FLUID_SIDE_STEP = 1e-6


def _fluid_side(mesh: ngs.Mesh, coords: np.ndarray, fluid: tuple[str, ...]) -> np.ndarray:
    """``coords`` with every point that the mesh search puts in a solid cell but that lies on a fluid cell's
    boundary (a point on Γ) moved by `FLUID_SIDE_STEP` of the mesh's size into that fluid cell, where the pressure
    lives (``fluid``: the fluid's cell regions)."""
    located = mesh(*(coords[:, k] for k in range(coords.shape[1])))
    solid = [i for i, nr in enumerate(located["nr"])
             if nr >= 0 and mesh[ngs.ElementId(ngs.VOL, int(nr))].mat not in fluid]
    if not solid:
        return coords
    points = np.array([v.point for v in mesh.vertices], dtype=float)
    step = FLUID_SIDE_STEP * max(float(np.ptp(points, axis=0).max()), 1.0)
    coords = coords.copy()
    directions = [np.array(c, float) - 1 for c in np.ndindex(*(3,) * coords.shape[1]) if any(np.array(c) != 1)]
    for i in solid:
        for d in directions:
            trial = coords[i] + step * d
            found = mesh(*trial)
            if found.nr >= 0 and mesh[ngs.ElementId(ngs.VOL, found.nr)].mat in fluid:
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

    def __init__(self, mesh: ngs.Mesh, points=(), lines=(), phases: Phases = Phases()):
        self.dim, self.fluid = mesh.dim, phases.fluid
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

    def _locate(self, mesh: ngs.Mesh, coords: np.ndarray, label: str):
        """The points this process evaluates (on a distributed mesh, MPI: those of its part that no lower rank
        has) with their mask among all points, and whether each is in a fluid cell. A point outside the mesh is a
        one-line `CaseError` with the mesh's bounding box; a point on Γ is evaluated in a fluid cell (`_fluid_side`)."""
        if not len(coords):
            return (None, np.zeros(0, dtype=bool)), np.zeros(0, dtype=bool)
        coords = _fluid_side(mesh, coords, self.fluid)
        located = mesh(*(coords[:, k] for k in range(coords.shape[1])))
        owner = parallel.owners(located["nr"] >= 0)
        outside = np.flatnonzero(owner < 0)
        if len(outside):
            i = int(outside[0])
            where = ", ".join(f"{c:g}" for c in coords[i])
            raise CaseError(f"{label.format(i)} at ({where}) is outside the mesh; expected a point in its "
                            f"bounding box {bounding_box(mesh)}")
        mine = owner == parallel.rank()
        fluid = np.array([mesh[ngs.ElementId(ngs.VOL, int(nr))].mat in self.fluid for nr in located["nr"][mine]])
        return (located[mine], mine), fluid

    def _evaluate(self, velocity, pressure, located, fluid) -> tuple[np.ndarray, np.ndarray]:
        (points, mine), n = located, len(located[1])
        values = np.zeros((n, self.dim + 1), dtype=complex if velocity.is_complex or pressure.is_complex else float)
        if mine.any():
            values[mine, :self.dim] = np.asarray(velocity(points)).reshape(-1, self.dim)
            values[mine, self.dim] = np.where(fluid, np.asarray(pressure(points)).reshape(-1), np.nan)
        values = parallel.total(values)  # each point's values come from one rank
        return values[:, :self.dim], values[:, self.dim]

    def sample(self, velocity, pressure) -> tuple[np.ndarray, np.ndarray]:
        """The point probes' values of the fields ``velocity`` and ``pressure`` (CoefficientFunctions, complex ones
        too): velocity (points × d) and pressure (NaN in the solid)."""
        return self._evaluate(velocity, pressure, self._point_locations, self._point_fluid)

    def record(self, scheme) -> None:
        """Append the values of the scheme's current state (step ``scheme.n``)."""
        step, time = int(scheme.n), float(scheme.time)
        row = [step, time]
        if len(self.points):
            velocity, pressure = self.sample(scheme.velocity, scheme.pressure)
            for v, p in zip(velocity, pressure):
                row += [float(c) for c in v] + [float(p)]
        self.probe_rows.append(row)
        for i, (coords, s, located, fluid) in enumerate(zip(self._line_points, self._line_s,
                                                            self._line_locations, self._line_fluid)):
            velocity, pressure = self._evaluate(scheme.velocity, scheme.pressure, located, fluid)
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
            atomic.write_text(path, csv_text(columns, rows))
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


def csv_text(columns: list[str], rows) -> str:
    """A CSV table: a header, then one line per row (whole numbers as such, every float to its last digit)."""
    lines = [",".join(columns)] + [",".join(_cell(c) for c in row) for row in rows]
    return "\n".join(lines) + "\n"
