"""Analytic test meshes made with numpy, and CAD parts made with FreeCAD (when available)."""
import functools
import importlib
import sys
from pathlib import Path

import numpy as np
import pytest

# The real parts of ../shared/data, beside the repository (never copied into it).
SHARED_STEP = Path(__file__).resolve().parents[2] / "shared" / "data" / "step"


def needs_shared_data(test):
    """Marks a test that reads ../shared/data. Without the data it fails and says so; it never
    skips silently."""
    @functools.wraps(test)
    def checked(*args, **kwargs):
        if not SHARED_STEP.is_dir():
            pytest.fail("this test reads the project's test data, which must sit beside the repository: %s is "
                        "missing" % SHARED_STEP.parent, pytrace=False)
        return test(*args, **kwargs)
    return checked


def icosphere(radius=1.0, subdivisions=4):
    """A sphere of nearly equilateral triangles, outward oriented."""
    t = (1.0 + 5 ** 0.5) / 2.0
    V = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
                  [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    F = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                  [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
                  [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    V = V / np.linalg.norm(V, axis=1)[:, None]
    for _ in range(subdivisions):
        midpoint = {}
        points = list(V)

        def middle(a, b):
            key = (min(a, b), max(a, b))
            if key not in midpoint:
                p = points[a] + points[b]
                points.append(p / np.linalg.norm(p))
                midpoint[key] = len(points) - 1
            return midpoint[key]

        faces = []
        for a, b, c in F:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            faces += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        V, F = np.array(points), np.array(faces)
    return V * radius, F.astype(np.int32)


def tube(radius=1.0, length=4.0, segments=64, rings=40):
    """An open cylinder around z with staggered rings (nearly equilateral triangles), outward."""
    V = []
    for i in range(rings + 1):
        offset = 0.5 * (i % 2)
        for j in range(segments):
            a = 2 * np.pi * (j + offset) / segments
            V.append([radius * np.cos(a), radius * np.sin(a), length * i / rings])
    F = []
    for i in range(rings):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            c, d = (i + 1) * segments + j, (i + 1) * segments + (j + 1) % segments
            if i % 2 == 0:
                F += [[a, b, c], [b, d, c]]
            else:
                F += [[a, b, d], [a, d, c]]
    return np.array(V, float), np.array(F, np.int32)


def grid(n=20, seed=0):
    """A flat square of 2 n² triangles with jittered interior vertices."""
    rng = np.random.default_rng(seed)
    xs, ys = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1))
    V = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)])
    interior = (xs.ravel() > 0) & (xs.ravel() < 1) & (ys.ravel() > 0) & (ys.ravel() < 1)
    V[interior, :2] += rng.uniform(-0.3, 0.3, (interior.sum(), 2)) / n
    F = []
    for i in range(n):
        for j in range(n):
            a = i * (n + 1) + j
            F += [[a, a + 1, a + n + 2], [a, a + n + 2, a + n + 1]]
    return V, np.array(F, np.int32)


def freecad():
    """FreeCAD's Part and MeshPart modules, or None when FreeCAD is not installed."""
    sys.path.append("/usr/lib/freecad-python3/lib")
    try:
        import FreeCAD  # noqa: F401  (must come before Part)
        import MeshPart
        import Part
    except ImportError:
        return None
    return FreeCAD, Part, MeshPart


def bracket_solid():
    """A 60 x 40 x 20 block with a through hole (r 8) and four vertical fillets (r 5): 11 faces."""
    FreeCAD, Part, _ = freecad()
    block = Part.makeBox(60, 40, 20).cut(Part.makeCylinder(8, 20, FreeCAD.Vector(30, 20, 0)))
    vertical = [e for e in block.Edges if e.Curve.__class__.__name__ == "Line"
                and abs(e.Vertexes[0].Point.z - e.Vertexes[-1].Point.z) > 19]
    return block.makeFillet(5, vertical)


def corner_blend_box():
    """A 10 mm cube whose three edges at one corner are rounded (r 2.5), meeting in a ball: 10 faces."""
    FreeCAD, Part, _ = freecad()
    box = Part.makeBox(10, 10, 10)
    corner = FreeCAD.Vector(10, 10, 10)
    return box.makeFillet(2.5, [e for e in box.Edges if any((v.Point - corner).Length < 1e-9 for v in e.Vertexes)])


def rounded_knob():
    """A turned knob, revolved about Z from its profile: a disc (r 20) under a 45° cone up to a flat
    top, its rims rounded: r 2 at the base and r 3 between disc and cone (tori that touch the disc on
    their outer equator), r 1.5 at the top (a torus between the cone and the top). 7 faces."""
    FreeCAD, Part, _ = freecad()
    V = FreeCAD.Vector
    s = np.sqrt(0.5)

    def arc(centre, radius, start, end):  # the shorter arc about centre (x, z) between two angles
        middle = 0.5 * (start + end)
        return Part.Arc(*[V(centre[0] + radius * np.cos(t), 0, centre[1] + radius * np.sin(t)) for t in (start, middle, end)])

    middle_z = 13 - 3 / s  # the r 3 fillet's centre: 3 from the disc (x 20) and from the cone (x + z = 30)
    top_x = 13.5 - 1.5 / s  # the r 1.5 fillet's centre: 1.5 from the top (z 18) and from the cone
    edges = [Part.LineSegment(V(0, 0, 0), V(18, 0, 0)).toShape(),
             arc((18, 2), 2, -np.pi / 2, 0).toShape(),
             Part.LineSegment(V(20, 0, 2), V(20, 0, middle_z)).toShape(),
             arc((17, middle_z), 3, 0, np.pi / 4).toShape(),
             Part.LineSegment(V(17 + 3 * s, 0, middle_z + 3 * s), V(top_x + 1.5 * s, 0, 16.5 + 1.5 * s)).toShape(),
             arc((top_x, 16.5), 1.5, np.pi / 4, np.pi / 2).toShape(),
             Part.LineSegment(V(top_x, 0, 18), V(0, 0, 18)).toShape(),
             Part.LineSegment(V(0, 0, 18), V(0, 0, 0)).toShape()]
    profile = Part.Face(Part.Wire(edges))
    return Part.Solid(profile.revolve(V(0, 0, 0), V(0, 0, 1), 360))


def slotted_head(dome=True):
    """A screw head about Z: a shaft (r 5, 10 long) under a 45° cone out to r 10 at z 5, topped by a
    dome revolved from an arc (r 20) centred 6 beyond the axis (a lemon: the inner part of a spindle
    torus, highest on the axis), or flat (dome=False); a slot 3 wide cut across it through the axis
    down to z 2, into the cone, whose rim then goes all round with two notches (their walls, hyperbolas
    on the cone, lean over the notch)."""
    FreeCAD, Part, _ = freecad()
    V = FreeCAD.Vector
    top = -7 + np.sqrt(20 ** 2 - 6 ** 2) if dome else 5.0
    if dome:
        t0, t1 = np.arctan2(5 + 7, 10 + 6), np.arctan2(top + 7, 6)
        crown = Part.Arc(*[V(-6 + 20 * np.cos(t), 0, -7 + 20 * np.sin(t)) for t in (t0, 0.5 * (t0 + t1), t1)]).toShape()
    else:
        crown = Part.LineSegment(V(10, 0, 5), V(0, 0, 5)).toShape()
    edges = [Part.LineSegment(V(0, 0, -10), V(5, 0, -10)).toShape(), Part.LineSegment(V(5, 0, -10), V(5, 0, 0)).toShape(),
             Part.LineSegment(V(5, 0, 0), V(10, 0, 5)).toShape(), crown,
             Part.LineSegment(V(0, 0, top), V(0, 0, -10)).toShape()]
    head = Part.Solid(Part.Face(Part.Wire(edges)).revolve(V(0, 0, 0), V(0, 0, 1), 360))
    return head.cut(Part.makeBox(30, 3, 20, V(-15, -1.5, 2))).removeSplitter()


def bent_rod():
    """A rod of r 5 bent through 90° about a radius of 15 between two straight runs of 40: cylinder,
    torus, cylinder, tangent where they meet, and two flat ends."""
    FreeCAD, Part, _ = freecad()
    V = FreeCAD.Vector
    first = Part.makeCylinder(5, 40, V(-40, 0, 0), V(1, 0, 0))
    bend = Part.makeTorus(15, 5, V(0, 15, 0), V(0, 0, 1), -180, 180, 90)
    bend.rotate(V(0, 15, 0), V(0, 0, 1), -90)
    second = Part.makeCylinder(5, 40, V(15, 15, 0), V(0, 1, 0))
    return first.fuse(bend).fuse(second).removeSplitter()


def hexagon_nut(across_flats=20.0, height=8.0, bore=5.0):
    """A hexagon nut chamfered at 30° on both ends: six flats, two end faces, a bore and twelve pieces
    of the two chamfer cones (one at each corner of each end), all about the Z axis."""
    FreeCAD, Part, _ = freecad()
    V = FreeCAD.Vector
    r = across_flats / 2
    corner = r / np.cos(np.pi / 6)
    prism = Part.Face(Part.makePolygon([V(corner * np.cos(np.pi / 3 * k), corner * np.sin(np.pi / 3 * k), 0)
                                        for k in range(7)])).extrude(V(0, 0, height))
    outside = corner + 1.0
    rise = (outside - r) * np.tan(np.radians(30))
    profile = Part.Face(Part.makePolygon([V(0, 0, 0), V(r, 0, 0), V(outside, 0, rise), V(outside, 0, height - rise),
                                          V(r, 0, height), V(0, 0, height), V(0, 0, 0)]))
    chamfered = prism.common(profile.revolve(V(0, 0, 0), V(0, 0, 1), 360))
    return chamfered.cut(Part.makeCylinder(bore, height)).removeSplitter()


def uniform_remesh(solid, triangles=40000):
    """A scanner's sampling of `solid`: a uniform remesh of about `triangles` triangles (sharp edges
    become chamfers) with the B-rep face of every triangle. Returns V, F, face, diagonal."""
    import idealize
    native = idealize._loader.native
    V, F, gt = tessellate_with_faces(solid, 0.01)
    length = np.sqrt(4 * triangle_areas(V, F).sum() / (np.sqrt(3) * triangles))
    V2, F2 = native.remesh_isotropic(V, F, length, 4)
    return V2, F2, gt[native.closest_faces(V, F, V2[F2].mean(axis=1))], np.linalg.norm(V2.max(0) - V2.min(0))


def normal_noise(V, F, diagonal, seed):
    """V moved along its vertex normals by Gaussian noise of 0.1 % of the diagonal (a scan's)."""
    import idealize
    normals = idealize.vertex_curvature(idealize.Mesh(V, F))["normal"]
    return V + normals * np.random.default_rng(seed).normal(0.0, 1e-3 * diagonal, (len(V), 1))


def tessellate_with_faces(solid, tolerance):
    """CAD-like tessellation with the B-rep face index of every triangle (shared edges welded).

    The whole solid is tessellated first, so that every face reuses the same edge discretization.
    """
    solid.tessellate(tolerance)
    V, F, gt = [], [], []
    for index, face in enumerate(solid.Faces):
        points, triangles = face.tessellate(tolerance)
        base = len(V)
        V += [[p.x, p.y, p.z] for p in points]
        F += [[base + a, base + b, base + c] for a, b, c in triangles]
        gt += [index] * len(triangles)
    unique, inverse = np.unique(np.round(np.array(V), 9), axis=0, return_inverse=True)
    F = inverse.reshape(-1)[np.array(F)]
    return unique, F.astype(np.int32), np.array(gt, np.int32)


def cad_export(solid, linear, angular):
    """What a CAD system's STL export gives: one BRepMesh run over the solid (shared edge vertices)
    with the given absolute linear and angular deflection, and the B-rep face of every triangle."""
    _, _, MeshPart = freecad()
    mesh = MeshPart.meshFromShape(Shape=solid, LinearDeflection=float(linear), AngularDeflection=float(angular),
                                  Relative=False, Segments=True)
    points, facets = mesh.Topology
    gt = np.empty(len(facets), np.int32)
    for face in range(mesh.countSegments()):  # one segment per face, in order
        gt[np.asarray(mesh.getSegment(face), np.int64)] = face
    V = np.array([(p.x, p.y, p.z) for p in points], np.float64)
    unique, inverse = np.unique(V, axis=0, return_inverse=True)  # weld the faces' shared edge vertices
    return unique, inverse.reshape(-1)[np.array(facets, np.int64)].astype(np.int32), gt


def quality_mesh(solid, max_length):
    """A mesh of `solid` whose triangles are about `max_length` and well shaped (FreeCAD's Mefisto
    mesher), its vertices on the solid's faces: a generated part's exact tessellation."""
    _, _, MeshPart = freecad()
    mesh = MeshPart.meshFromShape(Shape=solid, MaxLength=float(max_length))
    points, facets = mesh.Topology
    return np.array([(p.x, p.y, p.z) for p in points], np.float64), np.array(facets, np.int32)


def quality_layer(solid, max_length=2.0):
    """(the feature layer of quality_mesh(solid, max_length), solid): an exact layer to edit."""
    import idealize
    V, F = quality_mesh(solid, max_length)
    return idealize.idealize(idealize.Mesh(V, F)), solid


def min_angles(V, F):
    """The smallest angle of each triangle, in degrees."""
    corners = [V[F[:, i]] for i in range(3)]
    angles = []
    for i in range(3):
        u, v = corners[(i + 1) % 3] - corners[i], corners[(i + 2) % 3] - corners[i]
        cos = (u * v).sum(1) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
        angles.append(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    return np.min(angles, axis=0)


def triangle_areas(V, F):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def shared_part(name):
    """The largest solid of the STEP part `name` in ../shared/data/step."""
    _, Part, _ = freecad()
    return max(Part.read(str(SHARED_STEP / name)).Solids, key=lambda s: s.Volume)


def bench_module(module):
    """A module of bench/ (imported from beside tests/)."""
    bench = str(Path(__file__).resolve().parents[1] / "bench")
    if bench not in sys.path:
        sys.path.insert(0, bench)
    return importlib.import_module(module)


def benchmark_mesh(name, variant):
    """The benchmark's `variant` (one of datasets.VARIANTS) of the STEP part `name`, made (and
    cached) by bench/datasets.py: a mesh with V, F, gt (B-rep face per triangle) and face_types."""
    return bench_module("datasets").load_part(SHARED_STEP / name, [variant], log=lambda *_: None)[0]


def benchmark_truth(name):
    """What the B-rep benchmark compares with for the STEP part `name`: "faces", "surface_types"
    (faces on one surface joined), "volume" (bench/run_brep.py)."""
    return bench_module("run_brep").ground_truth_solid(name)
