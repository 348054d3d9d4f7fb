"""Pictures of the fitted solids of the real meshes: docs/images/real-<mesh file stem>.png.

Each closed real mesh of the test data (``mesh/`` in ``../shared/data``, override with
``IDEALIZE_DATA``) is converted once (``idealize.load_mesh``, ``idealize.idealize``,
``idealize.make_solid``) inside FreeCAD's GUI, its shape shown in a new document with one colour
per face, seen isometric and fitted, and saved as a 1000x800 PNG. One line per mesh goes to
stdout: the mesh, whether the shape is a valid closed solid, the share of the mesh's area on
analytic faces, the faces by surface type, the time.

Colours: plane light grey-blue, cylinder soft yellow, cone soft teal, sphere soft lavender, torus
soft rose, B-spline soft green, facets of faceted regions orange, any other face magenta. Edges
between two facets are drawn in a darker orange so that the facets do not turn into a black mesh;
all other edges are dark grey.

Run it from the repository root, with the native module built, either directly in FreeCAD's GUI
under a virtual X server::

    QTWEBENGINE_DISABLE_SANDBOX=1 xvfb-run -a -s "-screen 0 1280x1024x24" freecad bench/render_real.py [MESH ...]

or with FreeCAD's Python, which starts that command itself::

    /usr/bin/python3 bench/render_real.py [MESH ...]

MESH: file names or stems of meshes in the data's ``mesh/`` folder (e.g. ``fandisk casting``);
default all closed real meshes (dirty-scan-2019-03.stl is an open scan and is left out). Pass
stems to the ``freecad`` form: FreeCAD would try to open a name with a mesh extension itself.
The script quits FreeCAD when it is done (block.stl alone takes about 2 minutes).

With ``RENDER_REAL_BELOW=<folder>`` in the environment, a second picture of each solid seen from
the opposite side (isometric from below and behind) goes to ``<folder>/real-<stem>-below.png``,
to check the faces the documented view hides (keep that folder outside the repository).
"""
import os
import subprocess
import sys
import time
import traceback
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DATA = Path(os.environ.get("IDEALIZE_DATA", REPO.parent / "shared" / "data")).resolve()
MESH_DIR = DATA / "mesh"
IMAGES = REPO / "docs" / "images"
MESHES = ["MachinedPart2.stl", "abc_00000050_trimesh_000.stl", "block.stl", "casting.stl", "fandisk.obj",
          "fandisk_noisy0.1.off", "joint.stl", "occt_TR12J_OCC.stl"]
WIDTH, HEIGHT = 1000, 800

# Face colours by the class name of face.Surface.
SURFACE_COLORS = {
    "Plane": (0.80, 0.85, 0.95),          # light grey-blue
    "Cylinder": (0.98, 0.88, 0.55),       # soft yellow
    "Cone": (0.60, 0.85, 0.80),           # soft teal
    "Sphere": (0.78, 0.70, 0.92),         # soft lavender
    "Toroid": (0.95, 0.66, 0.72),         # soft rose
    "BSplineSurface": (0.70, 0.88, 0.60),  # soft green
}
FACET_COLOR = (1.0, 0.55, 0.10)           # orange
OTHER_COLOR = (0.90, 0.20, 0.90)          # magenta: a surface type none of the above
FACET_EDGE_COLOR = (0.80, 0.42, 0.05)     # edges between two facets
EDGE_COLOR = (0.15, 0.15, 0.15)


def log(text):
    """To the terminal: in FreeCAD's GUI, sys.stdout goes to the report view."""
    stream = sys.__stdout__ or sys.stdout
    stream.write(text + "\n")
    stream.flush()


def mesh_paths(names):
    """The mesh files named (file names or stems), default MESHES."""
    if not names:
        return [MESH_DIR / name for name in MESHES]
    paths = []
    for name in names:
        matches = [p for p in sorted(MESH_DIR.iterdir()) if name in (p.name, p.stem)]
        if not matches:
            raise SystemExit("no mesh %r in %s" % (name, MESH_DIR))
        paths.append(matches[0])
    return paths


def facet_faces(shape, solid):
    """Per face of `shape`: whether it is a facet of a faceted region. A planar face whose feature
    has a faceted region; when the feature also has a region of another kind, only its triangles
    (3 edges) count as facets."""
    faceted = {r["feature"] for r in solid.regions if r["kind"] == "faceted"}
    other = {r["feature"] for r in solid.regions if r["kind"] != "faceted"}
    features = solid.face_features
    if len(features) != len(shape.Faces):
        log("  warning: %d face features for %d faces; facets not told apart" % (len(features), len(shape.Faces)))
        return [False] * len(shape.Faces)
    return [type(face.Surface).__name__ == "Plane" and feature in faceted
            and (feature not in other or len(face.Edges) == 3)
            for face, feature in zip(shape.Faces, features)]


def edge_colors(shape, facet):
    """Per edge of `shape`: FACET_EDGE_COLOR when every face along it is a facet, else EDGE_COLOR."""
    index = {}
    for i, edge in enumerate(shape.Edges):
        index.setdefault(edge.hashCode(), []).append((i, edge))
    all_facets = [True] * len(shape.Edges)
    for face, is_facet in zip(shape.Faces, facet):
        if is_facet:
            continue
        for edge in face.Edges:
            for i, candidate in index.get(edge.hashCode(), []):
                if candidate.isSame(edge):
                    all_facets[i] = False
    return [FACET_EDGE_COLOR if f else EDGE_COLOR for f in all_facets]


def render(path):
    """Convert one mesh, save its picture; returns the line for the log."""
    import FreeCAD as App
    import FreeCADGui as Gui
    import idealize

    start = time.time()
    mesh = idealize.load_mesh(str(path))
    layer = idealize.idealize(mesh)
    solid = idealize.make_solid(layer)
    seconds = time.time() - start
    shape = solid.part_shape()

    facet = facet_faces(shape, solid)
    colors, counts = [], {}
    for face, is_facet in zip(shape.Faces, facet):
        kind = "facet" if is_facet else type(face.Surface).__name__
        counts[kind] = counts.get(kind, 0) + 1
        colors.append(FACET_COLOR if is_facet else SURFACE_COLORS.get(kind, OTHER_COLOR))

    doc = App.newDocument("render_" + "".join(c if c.isalnum() else "_" for c in path.stem))
    try:
        obj = doc.addObject("Part::Feature", "Solid")
        obj.Shape = shape
        doc.recompute()
        Gui.updateGui()
        view = obj.ViewObject
        view.LineWidth = 1
        view.PointSize = 1
        view.DiffuseColor = colors
        if shape.Edges:
            view.LineColorArray = edge_colors(shape, facet)
        Gui.updateGui()
        active = Gui.ActiveDocument.ActiveView
        active.viewIsometric()
        active.fitAll()
        Gui.updateGui()
        out = IMAGES / ("real-%s.png" % path.stem)
        active.saveImage(str(out), WIDTH, HEIGHT, "White")
        below = os.environ.get("RENDER_REAL_BELOW")
        if below:
            active.setViewDirection((1.0, -1.0, 1.0))  # isometric looks along (-1, 1, -1)
            active.fitAll()
            Gui.updateGui()
            active.saveImage(str(Path(below) / ("real-%s-below.png" % path.stem)), WIDTH, HEIGHT, "White")
    finally:
        App.closeDocument(doc.Name)

    types = ", ".join("%s %d" % (k, v) for k, v in sorted(counts.items(), key=lambda kv: -kv[1]))
    expected = solid.surface_types.get("facet", 0)
    note = "" if counts.get("facet", 0) == expected else " (solid reports %d facets)" % expected
    return ("%s: solid %s, analytic area fraction %.3f, %d faces (%s)%s, %d problems, %.0f s -> %s" % (
        path.name, "yes" if solid.solid else "NO (valid %s, closed %s)" % (solid.valid, solid.closed),
        solid.analytic_area_fraction, len(shape.Faces), types, note, len(solid.problems), seconds,
        out.relative_to(REPO)))


def run_in_gui(names):
    sys.path.insert(0, str(REPO))
    IMAGES.mkdir(parents=True, exist_ok=True)
    for path in mesh_paths(names):
        try:
            log(render(path))
        except Exception:
            log("%s: failed\n%s" % (path.name, traceback.format_exc()))


def launch(names):
    """Start this script in FreeCAD's GUI under xvfb-run."""
    env = dict(os.environ, QTWEBENGINE_DISABLE_SANDBOX="1")
    env.pop("QT_QPA_PLATFORM", None)  # must use the X server xvfb-run starts
    mesh_paths(names)  # unknown names fail here
    command = ["xvfb-run", "-a", "-s", "-screen 0 1280x1024x24", "freecad", str(Path(__file__).resolve())]
    return subprocess.run(command + [Path(n).stem if Path(n).suffix.lower() in (".stl", ".obj", ".off", ".ply")
                                     else n for n in names], env=env, cwd=str(REPO)).returncode


def _in_freecad_gui():
    app = sys.modules.get("FreeCAD")
    return app is not None and getattr(app, "GuiUp", False)


if _in_freecad_gui():
    try:
        run_in_gui(sys.argv[1:])
    finally:
        os._exit(0)  # quit FreeCAD (also keeps it from saving its preferences)
elif __name__ == "__main__":
    sys.exit(launch(sys.argv[1:]))
