"""Is a boundary a flat section of a tube? A straight segment (2D) or a planar disk (3D), with its centre, radius,
outward unit normal and measure (`detect_section`), or a one-line refusal (`SectionError`): what a flow-rate
inflow's profile needs (`fem.inflow`)."""
from __future__ import annotations

from dataclasses import dataclass

import ngsolve as ngs
import numpy as np

from ..runtime import parallel
from ..runtime.threads import integrate
from .regions import GeometryError

#: How far (relative to the section's size) a vertex may lie off the best-fit line or plane.
FLAT_TOLERANCE = 1e-6
#: How far (relative to the radius) a disk's rim vertices may lie off its circle; its area lies between the
#: inscribed rim polygon's and πr² (curved facets).
RIM_TOLERANCE = 1e-3


class SectionError(GeometryError):
    """A boundary that is not a straight segment (2D) or a planar disk (3D)."""


@dataclass(frozen=True)
class Section:
    """A straight segment (2D) or planar disk (3D) of the mesh: ``centre``, ``radius``, the domain's outward unit
    ``normal`` and the ``measure`` (length or area) of the meshed boundary."""

    name: str
    centre: np.ndarray
    radius: float
    normal: np.ndarray
    measure: float

    def radial(self) -> ngs.CoefficientFunction:
        """r = |x − c − ((x − c)·n) n|, the distance from the section's axis."""
        d = [xi - ci for xi, ci in zip((ngs.x, ngs.y, ngs.z), self.centre)]
        along = sum(di * ni for di, ni in zip(d, self.normal))
        return ngs.sqrt(sum((di - along * ni) ** 2 for di, ni in zip(d, self.normal)))


def _facets(mesh: ngs.Mesh, name: str) -> np.ndarray:
    """The vertex coordinates of the boundary's facets (facets × vertices × d), from every rank of a distributed
    mesh."""
    mask = mesh.Boundaries(name).Mask()
    local = [[mesh[v].point[: mesh.dim] for v in el.vertices] for el in mesh.Elements(ngs.BND) if mask[el.index]]
    facets = [f for part in parallel.gather(local) for f in part] if mesh.comm.size > 1 else local
    return np.array(facets, dtype=float).reshape(-1, mesh.dim, mesh.dim)


def detect_section(mesh: ngs.Mesh, name: str) -> Section:
    """The `Section` of boundary ``name``, or a one-line `SectionError` if it is not one straight segment (2D) or
    one flat disk (3D)."""
    facets = _facets(mesh, name)
    where, shape = f"boundary.{name}", "straight segment" if mesh.dim == 2 else "flat disk"
    if not len(facets):
        raise SectionError(f"{where}: no such boundary in the mesh")
    region = mesh.Boundaries(name)
    measure = integrate(ngs.CF(1.0), mesh, VOL_or_BND=ngs.BND, definedon=region)
    centroid = np.array([integrate(c, mesh, VOL_or_BND=ngs.BND, definedon=region)
                         for c in (ngs.x, ngs.y, ngs.z)[: mesh.dim]]) / measure
    outward = np.array([integrate(ngs.specialcf.normal(mesh.dim)[i], mesh, VOL_or_BND=ngs.BND, definedon=region)
                        for i in range(mesh.dim)]) / measure
    points = np.unique(facets.reshape(-1, mesh.dim), axis=0)
    _, _, axes = np.linalg.svd(points - centroid)
    normal = axes[-1] * (np.sign(axes[-1] @ outward) or 1.0)
    size = np.linalg.norm(points - centroid, axis=1).max()
    off = np.abs((points - centroid) @ normal).max()
    if off > FLAT_TOLERANCE * size or np.linalg.norm(outward) < 1 - 1e-8:
        raise SectionError(f"{where}: not a {shape} (a vertex is {off:.3g} off the best-fit "
                           f"{'line' if mesh.dim == 2 else 'plane'}, {off / size:.2g} of its size)")
    if mesh.dim == 2:
        along = (points - centroid) @ axes[0]
        radius = 0.5 * (along.max() - along.min())
        if abs(measure - 2 * radius) > FLAT_TOLERANCE * radius:
            raise SectionError(f"{where}: not one {shape} (length {measure:.6g}, extent {2 * radius:.6g})")
        return Section(name, centroid + 0.5 * (along.max() + along.min()) * axes[0], float(radius), normal,
                       float(measure))
    return _disk(where, facets, centroid, axes, normal, measure)


def _disk(where: str, facets: np.ndarray, centroid: np.ndarray, axes: np.ndarray, normal: np.ndarray,
          measure: float) -> Section:
    """A flat boundary's disk: its rim (the edges of one facet only) on one circle, its area that of the disk."""
    scale = np.abs(facets).max() or 1.0
    keys = np.round(facets / scale * 1e9).astype(np.int64)
    edges: dict[tuple, int] = {}
    for facet in keys:
        for a, b in ((0, 1), (1, 2), (2, 0)):
            edge = tuple(sorted((tuple(facet[a]), tuple(facet[b]))))
            edges[edge] = edges.get(edge, 0) + 1
    rim = np.unique(np.array([p for edge, count in edges.items() if count == 1 for p in edge]), axis=0)
    plane = (rim * scale / 1e9 - centroid) @ axes[:2].T
    # the least-squares circle u² + v² = 2au + 2bv + c through the rim, in the plane's coordinates
    (a, b, c), *_ = np.linalg.lstsq(np.column_stack((2 * plane, np.ones(len(plane)))), (plane**2).sum(axis=1),
                                    rcond=None)
    radius = float(np.sqrt(c + a * a + b * b))
    distances = np.linalg.norm(plane - (a, b), axis=1)
    if np.abs(distances - radius).max() > RIM_TOLERANCE * radius:
        raise SectionError(f"{where}: not a flat disk (its rim is {distances.min():.4g} to {distances.max():.4g} "
                           "from its centre)")
    angles = np.sort(np.arctan2(plane[:, 1] - b, plane[:, 0] - a))
    polygon = 0.5 * radius**2 * np.sum(np.sin(np.diff(np.append(angles, angles[0] + 2 * np.pi))))
    if not (1 - FLAT_TOLERANCE) * polygon <= measure <= (1 + FLAT_TOLERANCE) * np.pi * radius**2:
        raise SectionError(f"{where}: not a flat disk (area {measure:.6g}; a disk of this rim has {polygon:.6g} "
                           f"with flat facets, πr² = {np.pi * radius**2:.6g})")
    return Section(where.removeprefix("boundary."), centroid + a * axes[0] + b * axes[1], radius, normal,
                   float(measure))
