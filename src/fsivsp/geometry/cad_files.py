"""CAD files: the solids (2D: the plane faces) of a STEP, BREP or IGES file, each fluid or solid, glued
and meshed, with the interface and walls named."""
from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

import netgen.meshing as nm
import ngsolve as ngs
from netgen.occ import Glue, OCCGeometry

from .params import CAD_SUFFIXES, dimension, existing_file, fail, one_line, path_parameter, positive
from .regions import FLUID, FLUID_WALL, INTERFACE, SOLID, SOLID_WALL, GeometryError, check_regions, mesh_phases
from .shapes import occ_mesh


@contextlib.contextmanager
def _silenced():
    """Send what C++ code prints to stdout and stderr (OCC's parser messages) to /dev/null."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            os.dup2(null.fileno(), 2)
            yield
    finally:
        for fd, copy in zip((1, 2), saved):
            os.dup2(copy, fd)
            os.close(copy)


def _read_cad(path: str | Path, dim: int) -> tuple[Path, list]:
    """The parts of a STEP, BREP or IGES file (netgen's OCC kernel): its solids (3D) or its faces
    in the plane z = 0 (2D)."""
    path, suffix = existing_file(path, CAD_SUFFIXES, "CAD file")
    try:
        with _silenced(), tempfile.TemporaryDirectory() as folder:
            readable = path
            if suffix == ".igs":  # netgen's OCCGeometry knows the long suffix only
                readable = Path(folder) / "part.iges"
                readable.symlink_to(path.resolve())
            shape = OCCGeometry(str(readable)).shape
    except Exception as error:  # noqa: BLE001 - OCC raises bare Exceptions
        raise GeometryError(f"CAD file {path}: cannot read ({one_line(error)})") from None
    solids, faces = list(shape.solids), list(shape.faces)
    low, high = shape.bounding_box
    plane = max(abs(low[2]), abs(high[2])) <= 1e-6 * max(high[i] - low[i] for i in range(2))
    if dim == 3 and not solids:
        raise GeometryError(f"CAD file {path}: no solids" + (
            "" if not faces else " (plane faces: use dim = 2)" if plane else
            f", only {len(faces)} faces (IGES in face mode?): export the solids (STEP, BREP, or IGES in BRep mode)"))
    if dim == 2 and (solids or not faces):
        raise GeometryError(f"CAD file {path}: " + ("has solids: use dim = 3" if solids else "no faces"))
    if dim == 2 and not plane:
        raise GeometryError(f"CAD file {path}: a 2D geometry must lie in the plane z = 0")
    return path, solids if dim == 3 else faces


def _solid_regions(path: Path, parts: list, regions: Any, word: str) -> list[str]:
    """``fluid`` or ``solid`` for each part (a solid, or a face in 2D, as ``word`` says):
    ``regions[number]`` (from 1, as a string or an integer), else ``regions[its name]``, else its
    own name in the file."""
    if regions is None:
        regions = {}
    if not isinstance(regions, dict):
        raise fail("regions", f"a table mapping {word} names or numbers to 'fluid' or 'solid'", regions)
    names = [part.name for part in parts]
    listing = f"{word}s: " + ", ".join(f"{i} '{name}'" if name else f"{i} (unnamed)"
                                       for i, name in enumerate(names, start=1))
    regions = {str(key): value for key, value in regions.items()}
    for key, value in regions.items():
        if key not in names and key not in map(str, range(1, len(parts) + 1)):
            raise GeometryError(f"geometry.regions.{key}: no {word} of that name or number in {path} ({listing})")
        if value not in (FLUID, SOLID):
            raise fail(f"regions.{key}", f"'{FLUID}' or '{SOLID}'", value)
    media = [regions.get(str(i), regions.get(name, name)) for i, name in enumerate(names, start=1)]
    for i, medium in enumerate(media, start=1):
        if medium not in (FLUID, SOLID):
            raise GeometryError(f"geometry.regions: {word} {i} of {path} is neither '{FLUID}' nor '{SOLID}' "
                                f"({listing}); map it, e.g. regions = {{ \"{i}\" = \"{FLUID}\" }}")
    for medium in (FLUID, SOLID):
        if medium not in media:
            raise GeometryError(f"geometry.regions: no {word} of {path} is '{medium}' ({listing})")
    return media


def _boundary_parts(ngmesh: nm.Mesh) -> list[tuple[int, str, int, int]]:
    """(boundary number, name, domin, domout) of each face (3D) or edge (2D) descriptor."""
    if ngmesh.dim == 3:
        return [(fd.bc, fd.bcname, fd.domin, fd.domout) for fd in ngmesh.FaceDescriptors()]
    return [(ed.edgenr, ed.name, ed.domin, ed.domout) for ed in ngmesh.EdgeDescriptors()]


def kept_names(regions: Any) -> dict[str, str]:
    """The parts ``regions`` maps by a name of their own (neither fluid nor solid): their cell regions keep it, so
    that ``[materials.NAME]`` finds them (`cad`); {name: medium}."""
    if not isinstance(regions, dict):
        return {}
    return {str(k): v for k, v in regions.items() if not str(k).isdigit() and str(k) not in (FLUID, SOLID)}


def _name_boundaries(ngmesh: nm.Mesh, path: Path, media: dict[str, str]) -> None:
    """``interface`` on the faces (2D: edges) between fluid and solid; ``fluid_wall`` /
    ``solid_wall`` on the outer ones the CAD file leaves unnamed (netgen calls them ``default``).
    A boundary the file names ``interface`` elsewhere is refused. ``media``: the medium of each cell region."""
    materials = [media.get(name, name) for name in ngmesh.GetRegionNames(codim=0)]
    for number, name, domin, domout in _boundary_parts(ngmesh):
        media_here = {materials[d - 1] for d in (domin, domout) if d > 0}
        if media_here == {FLUID, SOLID}:
            ngmesh.SetBCName(number - 1, INTERFACE)
        elif name == INTERFACE:
            raise GeometryError(f"CAD file {path}: a boundary named '{INTERFACE}' is not shared by the fluid and "
                                f"the solid (it borders {' and '.join(sorted(media_here))} only)")
        elif name == "default" and 0 in (domin, domout):
            ngmesh.SetBCName(number - 1, FLUID_WALL if media_here == {FLUID} else SOLID_WALL)


def cad(dim: int = 3, maxh: float | None = None, *, path: str | Path | None = None, regions: Any = None) -> ngs.Mesh:
    """The solids (3D) or the faces in the plane z = 0 (2D) of a STEP (.step, .stp), BREP or IGES
    file, glued so that what they share is meshed conformingly, and meshed with ``maxh`` (default: a
    tenth of the bounding box's longest side). The mesh keeps its OCC geometry (``Curve``,
    projected refinement).

    Each solid (2D: face) is ``fluid`` or ``solid`` by `regions` (keys: numbers from 1 in file
    order, or names; values ``fluid`` / ``solid``) or else by its own name; its cell region is called by its
    medium, but a part mapped by a name of its own keeps that name (`kept_names`). The faces (2D: edges)
    shared by the fluid and the solid become ``interface`` (whatever the file calls them); other
    outer ones keep the file's name, else become ``fluid_wall`` / ``solid_wall``; those between two
    parts of the same medium are inner boundaries (named ``default``, traction-free)."""
    dim = dimension("cad", dim)
    h = None if maxh is None else positive("maxh", maxh)
    path, parts = _read_cad(path_parameter(path, CAD_SUFFIXES), dim)
    kept = kept_names(regions)
    for part, medium in zip(parts, _solid_regions(path, parts, regions, "solid" if dim == 3 else "face")):
        part.name = part.name if part.name in kept else medium  # netgen's region name of a solid (3D) or face (2D)
    shape = Glue(parts)
    if h is None:
        low, high = shape.bounding_box
        h = max(high[i] - low[i] for i in range(3)) / 10
    mesh = occ_mesh(shape, dim, h)
    _name_boundaries(mesh.ngmesh, path, kept)
    if INTERFACE not in mesh.GetBoundaries():
        raise GeometryError(f"CAD file {path}: no {'face' if dim == 3 else 'edge'} is shared by the fluid and the "
                            f"solid, so there is no '{INTERFACE}' (do they touch?)")
    check_regions(mesh, mesh_phases(mesh, kept))
    return mesh
