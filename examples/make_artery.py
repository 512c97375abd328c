"""Write examples/artery_3d.step and examples/artery_2d.step: an artery segment along x, the blood (``fluid``) in a
wall of two layers, the inner ``media`` and the outer ``adventitia`` (their own materials in the case files); the
faces (2D: edges) named ``inflow`` (x = 0) and ``outflow`` (x = L) of the blood, ``solid_ends`` of the wall,
``solid_wall`` its outer surface and ``layers`` the surface between the layers. 2D is the axial section: the
channel (0, L) × (−R, R) with the layers above and below.

Run: python examples/make_artery.py   (then: fsivsp run examples/artery_3d.toml, or artery_2d.toml)
"""
from pathlib import Path

from netgen.occ import Cylinder, Glue, MoveTo, Pnt, X, Y

HERE = Path(__file__).parent
#: the blood's radius, the segment's length, the media's and the adventitia's thickness (cm)
RADIUS, LENGTH, MEDIA, ADVENTITIA = 0.3, 4.0, 0.05, 0.03


def artery_3d():
    blood = Cylinder(Pnt(0, 0, 0), X, r=RADIUS, h=LENGTH, bottom="inflow", top="outflow", mantle="interface")
    middle = Cylinder(Pnt(0, 0, 0), X, r=RADIUS + MEDIA, h=LENGTH, bottom="solid_ends", top="solid_ends",
                      mantle="layers")
    outer = Cylinder(Pnt(0, 0, 0), X, r=RADIUS + MEDIA + ADVENTITIA, h=LENGTH, bottom="solid_ends", top="solid_ends",
                     mantle="solid_wall")
    media, adventitia = middle - blood, outer - middle
    blood.name, media.name, adventitia.name = "fluid", "media", "adventitia"
    return Glue([blood, media, adventitia])


def artery_2d():
    blood = MoveTo(0, -RADIUS).Rectangle(LENGTH, 2 * RADIUS).Face()
    blood.edges.Min(X).name, blood.edges.Max(X).name = "inflow", "outflow"
    blood.name = "fluid"
    parts = [blood]
    for sign in (1, -1):
        for name, inner, thickness in (("media", RADIUS, MEDIA), ("adventitia", RADIUS + MEDIA, ADVENTITIA)):
            bottom = inner if sign > 0 else -inner - thickness
            layer = MoveTo(0, bottom).Rectangle(LENGTH, thickness).Face()
            layer.edges.Min(X).name = layer.edges.Max(X).name = "solid_ends"
            outside, inside = (layer.edges.Max(Y), layer.edges.Min(Y)) if sign > 0 else (layer.edges.Min(Y),
                                                                                           layer.edges.Max(Y))
            (outside if name == "media" else inside).name = "layers"
            if name == "adventitia":
                outside.name = "solid_wall"
            layer.name = name
            parts.append(layer)
    return Glue(parts)


if __name__ == "__main__":
    for name, shape in (("artery_3d.step", artery_3d()), ("artery_2d.step", artery_2d())):
        shape.WriteStep(str(HERE / name))
        print(f"wrote {HERE / name}")
