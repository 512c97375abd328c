"""Write examples/channel_2d.msh (gmsh 4.1 ASCII): a fluid channel (0, 2) × (0.2, 0.6) over an elastic layer
(0, 2) × (0, 0.2), meshed by netgen, with the physical names ``fluid``, ``solid``, ``interface`` (y = 0.2),
``inflow`` (x = 0) and ``outflow`` (x = 2) of the fluid, ``fluid_wall`` (the top, y = 0.6) and ``solid_wall``
(the layer's bottom and ends).

Run: python examples/make_msh_example.py [OUT.msh]   (then: fsivsp run examples/channel_2d.toml)
"""
import sys
from pathlib import Path

import ngsolve as ngs
from netgen.occ import Glue, MoveTo, OCCGeometry, Rectangle, X, Y

from fsivsp.geometry.export import write_gmsh

OUT = Path(__file__).with_name("channel_2d.msh")


def channel(maxh: float = 0.1) -> ngs.Mesh:
    """The channel over the layer, named as in the module's docstring."""
    solid = Rectangle(2.0, 0.2).Face()
    fluid = MoveTo(0, 0.2).Rectangle(2.0, 0.4).Face()
    solid.edges.name, fluid.edges.name = "solid_wall", "fluid_wall"
    fluid.edges.Min(X).name, fluid.edges.Max(X).name = "inflow", "outflow"
    solid.edges.Max(Y).name = fluid.edges.Min(Y).name = "interface"
    solid.faces.name, fluid.faces.name = "solid", "fluid"
    return ngs.Mesh(OCCGeometry(Glue([solid, fluid]), dim=2).GenerateMesh(maxh=maxh))


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else OUT
    write_gmsh(channel(), out)
    print(f"wrote {out}")
