"""Meshes conforming to the interface, with the region names the scheme expects.

Every mesh fsivsp works on has the volume regions ``fluid`` and ``solid`` and the
boundary regions ``interface`` (Γ), ``fluid_wall`` (Γ_F) and ``solid_wall`` (Γ_S);
Γ_F or Γ_S may be empty (Fig. 1 of the paper).
"""
from __future__ import annotations

import ngsolve as ngs
import netgen.meshing as nm
from netgen.occ import Circle, Glue, OCCGeometry, Rectangle

FLUID, SOLID = "fluid", "solid"
INTERFACE, FLUID_WALL, SOLID_WALL = "interface", "fluid_wall", "solid_wall"


class GeometryError(ValueError):
    """A mesh without the regions the formulation needs."""


def paper_channel(maxh: float = 0.15, grading: float = 0.3) -> ngs.Mesh:
    """The domain of Section 5.3: Ω_F the disk of centre (0.2, 0.2), radius 0.05,
    Ω_S = (0, 2.5) × (0, 0.41) minus the disk (Γ_F = ∅). The defaults give the
    coarse mesh of about 128 vertices (136, 12 of them on Γ)."""
    channel = Rectangle(2.5, 0.41).Face()
    disk = Circle((0.2, 0.2), 0.05).Face()
    solid = channel - disk
    solid.faces.name, disk.faces.name = SOLID, FLUID
    solid.edges.name, disk.edges.name = SOLID_WALL, INTERFACE
    geometry = OCCGeometry(Glue([solid, disk]), dim=2)
    return ngs.Mesh(geometry.GenerateMesh(maxh=maxh, grading=grading))


def without_geometry(mesh: ngs.Mesh) -> ngs.Mesh:
    """A copy of a 2D mesh that has forgotten its geometry, so that ``Refine`` bisects
    edges without projecting the new nodes onto curved boundaries."""
    old = mesh.ngmesh
    if old.dim != 2:
        raise GeometryError("geometry-free refinement is implemented for 2D meshes only")
    new = nm.Mesh(dim=2)
    points = [new.Add(nm.MeshPoint(nm.Pnt(*p.p))) for p in old.Points()]
    for index, name in enumerate(old.GetRegionNames(codim=0), start=1):
        new.SetMaterial(index, name)
    for index, name in enumerate(old.GetRegionNames(codim=1)):
        new.SetBCName(index, name)
    for el in old.Elements2D():
        new.Add(nm.Element2D(el.index, [points[v.nr - 1] for v in el.vertices]))
    for el in old.Elements1D():
        new.Add(nm.Element1D([points[v.nr - 1] for v in el.vertices], index=el.index))
    return ngs.Mesh(new)


def refined(mesh: ngs.Mesh, levels: int, project: bool = True) -> ngs.Mesh:
    """``levels`` uniform refinements (each triangle into four). With ``project`` the
    new boundary and interface nodes are moved onto the true (curved) geometry."""
    mesh = ngs.Mesh(mesh.ngmesh.Copy()) if project else without_geometry(mesh)
    for _ in range(levels):
        mesh.Refine()
    return mesh


def check_regions(mesh: ngs.Mesh) -> None:
    """Refuse a mesh that lacks a fluid, a solid or an interface."""
    materials, boundaries = set(mesh.GetMaterials()), set(mesh.GetBoundaries())
    for name in (FLUID, SOLID):
        if name not in materials:
            raise GeometryError(f"mesh: no volume region named '{name}' (found {sorted(materials)})")
    if INTERFACE not in boundaries:
        raise GeometryError(f"mesh: no boundary region named '{INTERFACE}' (found {sorted(boundaries)})")


def region_counts(mesh: ngs.Mesh) -> dict[str, int]:
    """Vertices, cells and boundary vertices per region (for reports and the paper's dof count)."""
    def vertices(elements, name):
        return {v.nr for el in elements if el.mat == name for v in el.vertices}

    cells = list(mesh.Elements(ngs.VOL))
    boundary = list(mesh.Elements(ngs.BND))
    outer = vertices(boundary, FLUID_WALL) | vertices(boundary, SOLID_WALL)
    return {
        "vertices": mesh.nv,
        "cells": mesh.ne,
        "fluid_cells": sum(1 for el in cells if el.mat == FLUID),
        "fluid_vertices": len(vertices(cells, FLUID)),
        "boundary_vertices": len(outer),
        "interface_vertices": len(vertices(boundary, INTERFACE)),
    }


def interface_normal(mesh: ngs.Mesh) -> ngs.CoefficientFunction:
    """The unit normal on Γ pointing from Ω_F into Ω_S (the paper's n).

    NGSolve orients boundary normals per boundary element; the sign is fixed here once
    per mesh from the fluid cell adjacent to each interface facet.
    """
    normal = ngs.specialcf.normal(mesh.dim)
    coords = (ngs.x, ngs.y, ngs.z)[: mesh.dim]
    centre = (0.5,) if mesh.dim == 2 else (1 / 3, 1 / 3)
    signs = ngs.SurfaceL2(mesh, order=0, definedon=mesh.Boundaries(INTERFACE))
    sign = ngs.GridFunction(signs)
    for el in mesh.Elements(ngs.BND):
        if el.mat != INTERFACE:
            continue
        facet = el.edges[0] if mesh.dim == 2 else el.faces[0]
        fluid = [c for c in mesh[facet].elements if mesh[c].mat == FLUID]
        if len(fluid) != 1:
            raise GeometryError(f"mesh: interface facet {facet.nr} does not border exactly one fluid cell")
        trafo = mesh.GetTrafo(ngs.ElementId(el))  # must outlive the mesh point
        point = trafo(*centre)
        cell = [mesh[v].point for v in mesh[fluid[0]].vertices]
        into_solid = sum(n * (c(point) - sum(p[i] for p in cell) / len(cell))
                         for i, (n, c) in enumerate(zip(normal(point), coords)))
        sign.vec[signs.GetDofNrs(el)[0]] = 1.0 if into_solid > 0 else -1.0
    return sign * normal
