"""Write examples/cylinder_in_box.step: a fluid cylinder (radius 0.25, height 0.5, axis z) inside the
solid unit box, the solids named ``fluid`` and ``solid`` and the box's top face ``load``.

Run: python examples/make_cad_example.py [OUT.step]   (then: fsivsp run examples/cad_3d.toml)
"""
import sys
from pathlib import Path

from netgen.occ import Box, Cylinder, Glue, Pnt, Z

OUT = Path(__file__).with_name("cylinder_in_box.step")


def cylinder_in_box():
    """The glued solids: the box minus the cylinder (``solid``) and the cylinder (``fluid``)."""
    box = Box(Pnt(0, 0, 0), Pnt(1, 1, 1))
    box.faces.Max(Z).name = "load"
    fluid = Cylinder(Pnt(0.5, 0.5, 0.25), Z, r=0.25, h=0.5)
    solid = box - fluid
    solid.name, fluid.name = "solid", "fluid"
    return Glue([solid, fluid])


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else OUT
    cylinder_in_box().WriteStep(str(out))
    print(f"wrote {out}")
