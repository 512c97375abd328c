"""The 2D elastic tube as a channel for the boundary-condition tests: its materials (rigid or a compliant wall), data
at rest with given Dirichlet velocities and tractions, a scheme on it, the mean of a field over a boundary."""
from functools import cache

import ngsolve as ngs
import numpy as np

from fsivsp.fem.spaces import build_spaces
from fsivsp.geometry import elastic_tube, netgen_mesh, without_geometry
from fsivsp.model.data import Data
from fsivsp.model.expressions import parse_vector
from fsivsp.model.fields import Field
from fsivsp.model.materials import Materials
from fsivsp.timestepping.scheme import Scheme
from fsivsp.timestepping.schemes import time_scheme

#: The schemes by name, as `[time] scheme` (θ = 1/2: Crank–Nicolson).
SCHEMES = {"backward_euler": time_scheme("backward_euler"), "crank_nicolson": time_scheme("theta", 0.5),
           "bdf2": time_scheme("bdf2")}


def rigid(nu: float = 0.1, rho: float = 1.0) -> Materials:
    """A wall 10⁶ stiff: the channel is rigid to 1e-6."""
    return Materials.from_young(1e6, 0.3, rho_fluid=rho, rho_solid=1.0, nu=nu)


def at_rest(dim: int = 2, velocity: dict | None = None, traction: dict | None = None, **fields) -> Data:
    """v⁰ = u⁰ = 0 with Dirichlet ``velocity`` and ``traction`` (boundary → d expressions) and `Data` ``fields``."""
    vector = lambda values, where: Field(parse_vector([str(c) for c in values], where, dim))  # noqa: E731
    return Data(velocity0=Field([0] * dim), displacement0=Field([0] * dim),
                boundary_velocity={k: vector(v, k) for k, v in (velocity or {}).items()},
                boundary_traction={k: vector(v, k) for k, v in (traction or {}).items()}, **fields)


def compliant(young: float = 2e4) -> Materials:
    """A soft wall: the channel of `channel_scheme` breathes with the pressure."""
    return Materials.from_young(young, 0.3, rho_fluid=1.0, rho_solid=1.2, nu=0.05)


@cache
def tube(dim: int, maxh: float, length: float, radius: float = 0.5, wall: float = 0.1) -> ngs.Mesh:
    """The elastic tube's mesh, made once per test process (a scheme does not change it)."""
    return elastic_tube(dim, maxh, length=length, radius=radius, wall=wall)


def channel_scheme(data: Data, materials: Materials, dt: float, scheme: str = "bdf2", maxh: float = 0.1,
                   length: float = 2.0, dirichlet: str = "solid_ends|solid_wall", family: str = "taylor_hood",
                   dim: int = 2, solver=None, **walls) -> Scheme:
    """A `Scheme` on the elastic tube (``walls``: radius, wall; ``solver``: a `SolverSpec`)."""
    mesh = tube(dim, maxh, length, **walls)
    return Scheme(build_spaces(mesh, family, 1, dirichlet), materials, data, dt, solver=solver,
                  time_scheme=SCHEMES[scheme])


def history(run: Scheme, steps: int, **measures) -> dict[str, np.ndarray]:
    """March ``steps`` steps, recording ``time`` and each ``measures[name](scheme)`` after every step."""
    records = {"time": [], **{name: [] for name in measures}}

    def observe(scheme):
        records["time"].append(scheme.time)
        for name, measure in measures.items():
            records[name].append(measure(scheme))

    run.march(steps, observe)
    return {name: np.array(values) for name, values in records.items()}


def mean_over(mesh: ngs.Mesh, cf, name: str) -> float:
    """The mean of ``cf`` over boundary ``name``."""
    region = mesh.Boundaries(name)
    return (ngs.Integrate(cf, mesh, ngs.BND, definedon=region)
            / ngs.Integrate(ngs.CF(1.0), mesh, ngs.BND, definedon=region))


def relabelled(mesh: ngs.Mesh, length: float, name: str = "plaque") -> ngs.Mesh:
    """The same mesh (points, cells, facets, numbering) with its solid cells left of x = L/2 in the region ``name``
    (an internal solid–solid interface across both walls)."""
    old = without_geometry(mesh).ngmesh
    points = np.array([p.p for p in old.Points()], dtype=float)
    names = list(old.GetRegionNames(codim=0))
    solid = {i + 1 for i, region in enumerate(names) if region == "solid"}  # netgen: one index per wall
    names.append(name)
    cells = []
    for el in old.Elements2D():
        corners = [v.nr - 1 for v in el.vertices]
        moved = el.index in solid and points[corners, 0].mean() < length / 2
        cells.append((len(names) if moved else el.index, corners))
    boundaries = [(region, 0, 0) for region in old.GetRegionNames(codim=1)]
    facets = [(el.index, [v.nr - 1 for v in el.vertices]) for el in old.Elements1D()]
    return netgen_mesh(2, points, names, cells, boundaries, facets)
