"""Writes samples/bracket.stl: the bundled sample, a CAD-style STL export of a small bracket.

A 60 x 40 x 20 mm block with a through hole (r 8) and four vertical fillets (r 5): 11 faces, exported
with FreeCAD's tessellation at 0.05 mm like a CAD system's STL export (long thin triangles).
Run with Debian's /usr/bin/python3: /usr/bin/python3 tools/make_sample.py
"""
import os
import sys

sys.path.append("/usr/lib/freecad-python3/lib")
import FreeCAD  # noqa: E402  (must come before Part and Mesh)
import Mesh  # noqa: E402
import Part  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def bracket():
    block = Part.makeBox(60, 40, 20).cut(Part.makeCylinder(8, 20, FreeCAD.Vector(30, 20, 0)))
    vertical = [e for e in block.Edges if e.Curve.__class__.__name__ == "Line"
                and abs(e.Vertexes[0].Point.z - e.Vertexes[-1].Point.z) > 19]
    return block.makeFillet(5, vertical)


if __name__ == "__main__":
    os.makedirs(os.path.join(ROOT, "samples"), exist_ok=True)
    mesh = Mesh.Mesh(bracket().tessellate(0.05))
    path = os.path.join(ROOT, "samples", "bracket.stl")
    mesh.write(path)
    print("%s: %d triangles" % (path, mesh.CountFacets))
