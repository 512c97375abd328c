"""The VTK time series of a run with its ParaView collection (``.pvd``); every file written next to its final
name and moved into place, serially and as the pieces of a distributed run."""
from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path
from xml.sax.saxutils import quoteattr

import ngsolve as ngs
import numpy as np

from ..geometry import FLUID, SOLID
from ..runtime import parallel
from . import atomic
from .quantities import REGIONS


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
    """``{name}_{step:06d}.vtu`` files and the ParaView collection ``{name}.pvd``, of the cells or (``boundary``) of
    the facets of one boundary (the boundary mesh).

    Each step is written by `ngsolve.VTKOutput` under a hidden temporary name in the same
    directory and renamed into place; the ``.pvd`` (all files written so far, with their
    times) is then rewritten atomically. A write drops the entries of the same file and
    of later times, so a run resumed from a checkpoint replaces the steps after it.
    """

    def __init__(self, directory: str | Path, mesh: ngs.Mesh, fields: dict[str, ngs.CoefficientFunction],
                 name: str = "fields", subdivision: int = 0, refresh=None, continuous: bool = False,
                 boundary: str | None = None):
        """``refresh``, if given, is called before every write (see `SolidStress`); ``continuous``: one point
        per mesh vertex instead of VTKOutput's copy per cell (see `postprocess`)."""
        if not fields:
            raise ValueError("fields: expected at least one field to write")
        self.directory, self.mesh, self.name = Path(directory), mesh, name
        self.fields, self.subdivision, self.refresh = dict(fields), subdivision, refresh
        self.continuous = continuous
        self._drawn = None
        if boundary is not None:  # this rank's facets of the boundary
            self._drawn = ngs.BitArray(mesh.GetNE(ngs.BND))
            self._drawn.Clear()
            for el in mesh.Elements(ngs.BND):
                if el.mat == boundary:
                    self._drawn.Set(el.nr)
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
            self._output(path)
            if not written.is_file():
                raise RuntimeError(f"VTKOutput did not write {written.name}")
            os.replace(written, path)
        finally:
            written.unlink(missing_ok=True)
        self._finish(path)

    def _output(self, path: Path) -> None:
        """NGSolve's VTKOutput of the fields under the name ``path`` (it appends .vtu), of the cells or the
        boundary's facets."""
        output = ngs.VTKOutput(self.mesh, coefs=list(self.fields.values()), names=list(self.fields),
                               filename=str(path), subdivision=self.subdivision)
        if self._drawn is None:
            output.Do()
        else:
            output.Do(vb=ngs.BND, drawelems=self._drawn)

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
        self._output(scratch)
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
        home = HOME.get(name.removesuffix("_real").removesuffix("_imag"))   # a complex field's parts too
        weight = np.ones(len(points)) if home is None else (copy_region == home).astype(float)
        total = np.zeros((len(unique), flat.shape[1]))
        np.add.at(total, index, flat * weight[:, None])
        count = np.zeros(len(unique))
        np.add.at(count, index, weight)
        mean = total / np.maximum(count, 1)[:, None]
        merged[name] = mean.reshape((len(unique),) + values.shape[1:])
    merged["region"] = np.asarray(merged["region"]).round()
    return points[first], index[cells], merged
