"""The fitted B-rep (issue 4): analytic parts round-trip mesh -> feature layer -> solid -> STEP."""
import numpy as np
import pytest

import idealize
import shapes
from idealize.mesh import Mesh
from test_features import bracket_scan, countersink, noisy_scan, spherical_dimple, torus_blend, wavy_top  # noqa: F401 (fixtures)

needs_freecad = pytest.mark.skipif(shapes.freecad() is None, reason="FreeCAD is not installed")


def box():
    _, Part, _ = shapes.freecad()
    return Part.makeBox(60, 40, 20)


def box_with_hole():
    FreeCAD, Part, _ = shapes.freecad()
    return Part.makeBox(60, 40, 20).cut(Part.makeCylinder(8, 20, FreeCAD.Vector(30, 20, 0)))


SURFACE_NAMES = {"Plane": "plane", "Cylinder": "cylinder", "Cone": "cone", "Sphere": "sphere", "Toroid": "torus"}


def surface_types(solid):
    counts = {}
    for face in solid.removeSplitter().Faces:
        name = SURFACE_NAMES.get(type(face.Surface).__name__, "other")
        counts[name] = counts.get(name, 0) + 1
    return counts


def covered_area(solid, deflection):
    """The area of the solid's mesh at `deflection`: its surface's, less what no facet covers."""
    V, F = solid.triangulate(deflection)
    return 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum()


def solid_of(part, tolerance=0.05, noise=0.0):
    V, F, _ = shapes.tessellate_with_faces(part, tolerance)
    if noise:
        V = V + np.random.default_rng(1).normal(0.0, noise, V.shape)
    layer = idealize.idealize(Mesh(V, F))
    return layer, idealize.make_solid(layer)


def drilled_block():
    """A blind hole with a 118° drill point: a cone bounded by one circle and its apex."""
    FreeCAD, Part, _ = shapes.freecad()
    radius, depth = 5.0, 12.0
    tip = radius / np.tan(np.radians(59))
    hole = Part.makeCylinder(radius, depth, FreeCAD.Vector(20, 15, 20 - depth))
    point = Part.makeCone(0, radius, tip, FreeCAD.Vector(20, 15, 20 - depth - tip))
    return Part.makeBox(40, 30, 20).cut(hole.fuse(point)).removeSplitter()


def ball_end_pocket():
    """A pocket a ball-end mill leaves: a hemisphere bounded by one circle about its pole."""
    FreeCAD, Part, _ = shapes.freecad()
    cutter = Part.makeCylinder(6, 10, FreeCAD.Vector(20, 15, 10)).fuse(Part.makeSphere(6, FreeCAD.Vector(20, 15, 10)))
    return Part.makeBox(40, 30, 20).cut(cutter).removeSplitter()


def bevelled_bore():
    """A bore through a block whose top is bevelled at 30°: the oblique plane cuts it in an ellipse."""
    FreeCAD, Part, _ = shapes.freecad()
    block = Part.makeBox(60, 40, 30).cut(Part.makeCylinder(8, 30, FreeCAD.Vector(30, 20, 0)))
    keep = Part.makeBox(100, 100, 100, FreeCAD.Vector(-20, -30, 0))
    keep.rotate(FreeCAD.Vector(0, 0, 18), FreeCAD.Vector(0, 1, 0), -30)
    return block.common(keep).removeSplitter()


@needs_freecad
@pytest.mark.parametrize("make", [drilled_block, ball_end_pocket])
@pytest.mark.parametrize("export", [False, True])
def test_caps_about_an_apex_or_a_pole(make, export):
    part = make()
    if export:  # a CAD system's coarse STL export
        V, F, _ = shapes.cad_export(part, 1e-3 * part.BoundBox.DiagonalLength, 0.35)
    else:
        V, F, _ = shapes.tessellate_with_faces(part, 0.05)
    solid = idealize.make_solid(idealize.idealize(Mesh(V, F)))
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == surface_types(part)
    assert solid.volume == pytest.approx(part.Volume, rel=1e-6)


def euler_characteristic(part):
    """V - E + F of a FreeCAD shape's faces (a face of w wires counts 2 - w; degenerate edges none)."""
    edges = [e for e in part.Edges if not e.Degenerated]
    vertices = {v.hashCode() for e in edges for v in e.Vertexes}
    return len(vertices) - len(edges) + sum(2 - len(f.Wires) for f in part.Faces)


@needs_freecad
@pytest.mark.parametrize("make", [box, box_with_hole, shapes.bracket_solid, countersink, spherical_dimple,
                                  torus_blend, bevelled_bore])
def test_round_trip_of_analytic_parts(make, tmp_path):
    part = make()
    layer, solid = solid_of(part)
    assert solid.solid and solid.valid and solid.closed, solid.problems
    assert solid.problems == []
    assert solid.surface_types == surface_types(part)
    assert solid.faces == len(part.removeSplitter().Faces)
    assert solid.euler["solid"] == solid.euler["mesh"] == euler_characteristic(part)
    assert solid.volume == pytest.approx(part.Volume, rel=1e-4)
    # Every input vertex lies on the solid (CAD tessellation: up to the chordal deviation).
    assert solid.max_deviation < 0.06
    # Each face names its feature, of the face's type (merged periodic faces too).
    feature_types = {f["id"]: f["type"] for f in layer.features}
    faces = solid.part_shape().Faces
    assert len(solid.face_features) == len(faces)
    for face, feature in zip(faces, solid.face_features):
        assert feature_types.get(feature) == SURFACE_NAMES[type(face.Surface).__name__]
    # The STEP file re-imports in FreeCAD as one valid solid with the same faces.
    _, Part, _ = shapes.freecad()
    path = tmp_path / "part.step"
    solid.write_step(path)
    back = Part.read(str(path))
    assert len(back.Solids) == 1 and back.Solids[0].isValid()
    assert len(back.Faces) == solid.faces
    assert back.Solids[0].Volume == pytest.approx(solid.volume, rel=1e-9)
    # ... and so does the BRep text handed to FreeCAD's documents.
    shape = solid.part_shape()
    assert shape.isValid() and len(shape.Faces) == solid.faces


@needs_freecad
def test_noisy_scan_of_the_bracket_gives_the_designed_solid(noisy_scan):
    """The uniform re-sampling of the bracket with noise of 0.1 % of the diagonal (as in
    test_features): the designed solid, its volume within 0.5 %."""
    V, F, gt, diag, layer = noisy_scan
    solid = idealize.make_solid(layer)
    assert solid.solid, solid.problems
    assert solid.surface_types == {"plane": 6, "cylinder": 5}
    assert solid.volume == pytest.approx(shapes.bracket_solid().Volume, rel=5e-3)
    assert solid.max_deviation < 5e-3 * diag


@needs_freecad
@pytest.mark.parametrize("tolerance", [0.05, 0.01])
def test_a_face_a_notch_cuts_off_stays_a_face(tolerance):
    """A notch (a half hole) near the end of a block cuts its side face in two: a long piece and a
    piece a tenth as large, on one plane. The small piece is its own face; it used to join the end
    face beside it (the neighbour it shares most border with), whose plane is square to it, and the
    solid lost that face and 1 % of its volume."""
    FreeCAD, Part, _ = shapes.freecad()
    part = Part.makeBox(100, 20, 20).cut(Part.makeCylinder(2, 20, FreeCAD.Vector(95, 0, 0)))
    V, F, _ = shapes.tessellate_with_faces(part, tolerance)
    solid = idealize.make_solid(idealize.idealize(Mesh(V, F)))
    assert solid.solid and solid.analytic_area_fraction == pytest.approx(1.0)
    assert solid.faces == len(part.Faces)
    assert solid.volume == pytest.approx(part.Volume, rel=1e-6)


@needs_freecad
@shapes.needs_shared_data
def test_a_face_healing_cannot_keep_fails_alone():
    """On this part's CAD tessellation a band of a torus has two loops that OpenCASCADE's healing
    cannot join: it kept four of the band's 106 edges. The band's neighbours then had free edges,
    were blamed for them, and went to facets one after another (19 of 112 regions analytic). The
    band alone fails; every other face stays analytic."""
    mesh = shapes.benchmark_mesh("as_isolated_blends_test_28.step", "cad")
    layer = idealize.idealize(Mesh(mesh.V, mesh.F))
    solid = idealize.make_solid(layer)
    assert solid.solid
    failed = [r for r in solid.regions if r["kind"] != "analytic"]
    assert all(layer.features[r["feature"]]["type"] == "torus" for r in failed), [r["reason"] for r in failed]


@needs_freecad
def test_tangent_edges_are_exact():
    """A fillet meets its planes along lines of tangency: the edges are closed-form curves on both
    surfaces, not fitted ones."""
    layer, solid = solid_of(shapes.bracket_solid())
    curves = [e["curve"] for e in solid._brep.edges]
    assert curves and all(c == "closed form" for c in curves)


@needs_freecad
@pytest.mark.parametrize("export", [None, 5e-4, 2e-3])
def test_freeform_top_becomes_a_bspline_face(export, tmp_path):
    """The wavy top, a freeform feature, gets a B-spline surface fitted to its vertices, which the
    sides' planes cut: a valid solid of the part's faces and volume, in STEP too, whose freeform
    primitive is that B-spline's face. Before, the top had no face and the part no solid. (None: the
    fine tessellation; else a CAD export at that share of the diagonal, 0.35 rad.)"""
    part = wavy_top()
    if export is None:
        V, F, _ = shapes.tessellate_with_faces(part, 0.05)
    else:
        V, F, _ = shapes.cad_export(part, export * part.BoundBox.DiagonalLength, 0.35)
    layer = idealize.idealize(Mesh(V, F))
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.valid and solid.problems == [], solid.problems
    assert solid.surface_types == {"bspline": 1, "plane": 5}
    assert solid.volume == pytest.approx(part.Volume, rel=2e-4)
    assert solid.max_deviation < 2e-3 * part.BoundBox.DiagonalLength
    _, Part, _ = shapes.freecad()
    path = tmp_path / "wavy.step"
    solid.write_step(path)
    back = Part.read(str(path))
    assert len(back.Solids) == 1 and back.Solids[0].isValid() and len(back.Faces) == 6
    from idealize.freecad.solid import primitive_shape
    labels = np.asarray(layer.labels)
    [freeform] = [f for f in layer.features if f["type"] == "freeform"]
    faces = F[labels == freeform["id"]]
    normals = np.cross(V[faces[:, 1]] - V[faces[:, 0]], V[faces[:, 2]] - V[faces[:, 0]])
    face = primitive_shape(freeform, V[np.unique(faces)], normals / np.linalg.norm(normals, axis=1)[:, None])
    assert face.isValid() and type(face.Surface).__name__ == "BSplineSurface"
    assert face.Area > part.Faces[[type(f.Surface).__name__ for f in part.Faces].index("BSplineSurface")].Area


def test_a_ball_corner_of_an_open_shell_is_kept():
    """Three fillets meeting in a ball, on a box whose bottom is missing: the shell cannot close, so
    each face must pass the boolean operations' check to be kept. The ball's rims are circles that
    are no parallels of its sphere, whose pcurves are approximations: the edges' tolerances must
    cover them, or the ball is dropped (as nist_ftc_06's two balls were)."""
    from idealize._loader import native
    part = shapes.corner_blend_box()
    V, F, face = shapes.tessellate_with_faces(part, 0.01)
    bottom = [i for i, f in enumerate(part.Faces) if f.BoundBox.ZMax < 1e-9]
    assert len(bottom) == 1
    keep = face != bottom[0]
    types, params = [], []
    for f in part.Faces:
        s = f.Surface
        kind = {"Plane": "plane", "Cylinder": "cylinder", "Sphere": "sphere"}[type(s).__name__]
        types.append(kind)
        params.append({"normal": tuple(s.Axis), "point": tuple(s.Position)} if kind == "plane" else
                      {"axis": tuple(s.Axis), "point": tuple(s.Center), "radius": s.Radius} if kind == "cylinder" else
                      {"center": tuple(s.Center), "radius": s.Radius})
    brep = native.build_brep(V, F[keep], face[keep], types, params)
    assert not brep.solid and brep.valid
    assert brep.surface_types == {"plane": 5, "cylinder": 3, "sphere": 1}, brep.problems
    assert [message for _, message in brep.problems] == ["the faces do not close into a solid (free edges remain)"]


def wavy_drum():
    """A drum lofted through three closed B-spline curves of radius 15 ± 1.5 (three waves): a
    freeform side all round its axis, between two planes."""
    FreeCAD, Part, _ = shapes.freecad()
    wires = []
    for z in (0.0, 10.0, 20.0):
        t = np.linspace(0, 2 * np.pi, 24, endpoint=False)
        r = 15 + 1.5 * np.sin(3 * t + z / 8)
        curve = Part.BSplineCurve()
        curve.interpolate([FreeCAD.Vector(a * np.cos(b), a * np.sin(b), z) for a, b in zip(r, t)], PeriodicFlag=True)
        wires.append(Part.Wire(curve.toShape()))
    return Part.makeLoft(wires, True)


@needs_freecad
def test_a_freeform_side_without_a_surface_becomes_facets_and_the_drum_closes():
    """A freeform side that goes all round the drum is no height field over any plane: it gets no
    surface, and its feature is named with the reason. It becomes its own triangles as planar
    facets, and the drum closes with its two analytic end planes (before: the side had no face and
    the planes came back as an open shell). (Its faces labelled as the part's own, freeform and
    planes.)"""
    from idealize._loader import native
    part = wavy_drum()
    V, F, face = shapes.tessellate_with_faces(part, 0.05)
    types = ["freeform" if type(f.Surface).__name__ == "BSplineSurface" else "plane" for f in part.Faces]
    assert sorted(types) == ["freeform", "plane", "plane"]
    params = [{} if t == "freeform" else {"normal": tuple(f.Surface.Axis), "point": tuple(f.Surface.Position)}
              for t, f in zip(types, part.Faces)]
    brep = native.build_brep(V, F, face, types, params)
    side = types.index("freeform")
    assert brep.solid and brep.closed and brep.valid
    assert any(feature == side and "folds" in message for feature, message in brep.problems), brep.problems
    assert brep.surface_types["plane"] == 2 and brep.surface_types["facet"] > 100
    kinds = {r["feature"]: r["kind"] for r in brep.regions}
    assert kinds[side] == "faceted" and sorted(kinds.values()) == ["analytic", "analytic", "faceted"]
    assert brep.volume == pytest.approx(abs(part.Volume), rel=0.01)


@needs_freecad
def test_deterministic():
    part = shapes.bracket_solid()
    V, F, _ = shapes.tessellate_with_faces(part, 0.02)
    V = V + np.random.default_rng(2).normal(0.0, 0.02, V.shape)
    first = idealize.make_solid(idealize.idealize(Mesh(V, F)))
    second = idealize.make_solid(idealize.idealize(Mesh(V, F)))
    assert first.brep_string() == second.brep_string()


def test_bad_parameters_are_refused():
    from idealize._loader import native
    V, F = shapes.icosphere(radius=1.0, subdivisions=2)
    labels = np.zeros(len(F), np.int32)
    with pytest.raises(ValueError, match="lack 'radius'"):
        native.build_brep(V, F, labels, ["sphere"], [{"center": (0, 0, 0)}])
    with pytest.raises(ValueError, match="unknown surface type"):
        native.build_brep(V, F, labels, ["blob"], [{}])
    with pytest.raises(ValueError, match="one label per triangle"):
        native.build_brep(V, F, labels[:-1], ["sphere"], [{"center": (0, 0, 0), "radius": 1.0}])


def test_whole_sphere():
    """A closed surface without any edge: a sphere face bounded by nothing."""
    V, F = shapes.icosphere(radius=10.0, subdivisions=3)
    solid = idealize.make_solid(idealize.idealize(Mesh(V, F)))
    assert solid.solid, solid.problems
    assert solid.surface_types == {"sphere": 1}
    assert solid.volume == pytest.approx(4 / 3 * np.pi * 1000, rel=1e-3)


@needs_freecad
def test_inconsistent_layers_never_crash():
    """Labels and surfaces that do not fit together (as a failed identification can leave them)
    give a result or a clear error, never a crash of the process (OpenCASCADE's healing faults on
    such shapes; the faults are turned into errors)."""
    from idealize._loader import native
    part = shapes.bracket_solid()
    V, F, _ = shapes.tessellate_with_faces(part, 0.05)
    layer = idealize.idealize(Mesh(V, F))
    rng = np.random.default_rng(3)
    types = [f["type"] for f in layer.features]
    for trial in range(6):
        labels = np.asarray(layer.labels).copy()
        flip = rng.random(len(labels)) < 0.05 * (trial + 1)
        labels[flip] = rng.integers(0, len(types), flip.sum())
        params = [dict(f["params"]) for f in layer.features]
        for p in params:  # move every surface a little
            for key in ("point", "center", "apex"):
                if key in p:
                    p[key] = tuple(np.asarray(p[key]) + rng.normal(0, 0.5, 3))
        try:
            brep = native.build_brep(V, F, labels, types, params, 0.06)
        except RuntimeError as error:
            assert "B-rep construction failed" in str(error)
            continue
        assert brep.faces >= 0 and (brep.valid or not brep.solid)


@needs_freecad
def test_document_objects_without_gui(tmp_path):
    """make_solid_object works in a GUI-less FreeCAD (freecadcmd, plain Python): a Part solid, a
    group with one primitive per feature, the source mesh untouched; export_step writes it."""
    FreeCAD, Part, _ = shapes.freecad()
    import Mesh
    from idealize.freecad import solid as freecad_solid
    part = shapes.bracket_solid()
    V, F, _ = shapes.tessellate_with_faces(part, 0.05)
    doc = FreeCAD.newDocument("IdealizeBrepTest")
    try:
        source = doc.addObject("Mesh::Feature", "Bracket")
        source.Mesh = Mesh.Mesh([[tuple(V[i]) for i in tri] for tri in F])
        before = source.Mesh.CountFacets
        obj, group, solid = freecad_solid.make_solid_object(doc, source)
        doc.recompute()
        assert obj.Label == "Bracket_Solid" and obj.IdealizeSolid and obj.IdealizeProblems == []
        assert obj.Shape.isValid() and obj.Shape.ShapeType == "Solid" and len(obj.Shape.Faces) == 11
        assert obj.Shape.Volume == pytest.approx(part.Volume, rel=1e-4)
        kinds = sorted(o.Name.split("_", 1)[1] for o in group.Group)
        assert kinds == ["cylinder"] * 5 + ["plane"] * 6
        # Each primitive covers its face: the solid's face centres lie on the primitives.
        for o in group.Group:
            assert o.Shape.isValid()
        for face in obj.Shape.Faces:
            centre = face.valueAt(*[(a + b) / 2 for a, b in zip(face.ParameterRange[::2], face.ParameterRange[1::2])])
            assert min(o.Shape.distToShape(Part.Vertex(centre))[0] for o in group.Group) < 1e-6
        assert source.Mesh.CountFacets == before
        path = tmp_path / "bracket.step"
        freecad_solid.export_step([obj], path)
        back = Part.read(str(path))
        assert len(back.Solids) == 1 and len(back.Faces) == 11
    finally:
        FreeCAD.closeDocument(doc.Name)


def solid_of_export(part):
    """The solid made from the STL export the benchmark gives a part (0.1 % of its diagonal, 0.35 rad)."""
    V, F, _ = shapes.cad_export(part, 1e-3 * part.BoundBox.DiagonalLength, 0.35)
    return idealize.make_solid(idealize.idealize(Mesh(V, F)))


def assert_step_round_trip(solid, tmp_path):
    """The solid's STEP file reads back as one valid solid with its faces."""
    _, Part, _ = shapes.freecad()
    path = tmp_path / "solid.step"
    solid.write_step(path)
    back = Part.read(str(path))
    assert len(back.Solids) == 1 and back.Solids[0].isValid() and len(back.Faces) == solid.faces


def benchmark_solid_of_its_part(name, variant):
    """The benchmark's `variant` mesh of the STEP part `name`, its feature layer and solid, asserted
    to be the part's: a valid solid with its faces, surfaces and volume (within 0.05 %)."""
    m = shapes.benchmark_mesh(name, variant)
    truth = shapes.benchmark_truth(name)
    layer = idealize.idealize(Mesh(m.V, m.F))
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.valid and solid.part_shape().isValid(), solid.problems
    assert solid.surface_types == truth["surface_types"]
    assert solid.faces == truth["faces"]
    assert abs(solid.volume / truth["volume"] - 1) < 5e-4
    return m, layer, solid


def assert_faces_mesh(solid, types=("Plane", "Cylinder", "Cone", "Sphere", "Toroid")):
    """OpenCASCADE's mesher (FreeCAD's display) covers each face of the given surface types: a face
    whose boundary has gaps that vertex tolerances bridge may come out empty or spill over."""
    shape = solid.part_shape()
    deflection = 1e-4 * shape.BoundBox.DiagonalLength
    for i, face in enumerate(shape.Faces):
        if type(face.Surface).__name__ not in types:
            continue
        points, triangles = face.tessellate(deflection)
        P, T = np.array([tuple(p) for p in points]), np.array(triangles).reshape(-1, 3)
        area = 0.5 * np.linalg.norm(np.cross(P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]), axis=1).sum() if len(T) else 0
        assert abs(area - face.Area) <= 1e-2 * face.Area, (i, type(face.Surface).__name__, face.Area, area)


@needs_freecad
@shapes.needs_shared_data
@pytest.mark.parametrize("name", ["as_bolt-colored-faces.stp", "as_isolated_blends_test_12.stp", "occt_mal_vis.step",
                                  "nist_ctc_01_asme1_rd.stp", "as_bb_boxblend_03.stp"])
def test_cad_export_of_a_real_part_gives_its_solid(name):
    """Real parts whose full cylindrical bands (a bolt's shank, cylinders a STEP file splits in
    halves) bound their faces with whole circles, with drill points (ctc_01) and slivers of two
    triangles whose six corners a cone would fit: the solid closes, with the part's volume."""
    part = shapes.shared_part(name)
    solid = solid_of_export(part)
    assert solid.solid and solid.valid, solid.problems
    assert abs(solid.volume / part.Volume - 1) < 5e-3


@needs_freecad
@shapes.needs_shared_data
@pytest.mark.parametrize("name, types", [
    ("nist_ftc_11_asme1_rb.stp", {"plane": 2, "cylinder": 2, "torus": 2}),
    # Of the STEP file's 14 cone faces, pairs lie on one cone (the file splits them at a seam).
    ("occt_Pump_Nut.step", {"plane": 8, "cylinder": 1, "cone": 12, "torus": 2}),
])
def test_cad_export_of_coarse_tori_gives_the_parts_faces(name, types):
    """Fillets of 1-1.5 mm on parts of 50-90 mm: the export crosses their tubes in a few facets
    turning by up to 54° on the saddle, and segmentation cuts them into bands and single facets.
    The solid has the part's surfaces and volume."""
    part = shapes.shared_part(name)
    solid = solid_of_export(part)
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == types
    assert abs(solid.volume / part.Volume - 1) < 5e-4


@needs_freecad
@shapes.needs_shared_data
def test_cad_export_of_corner_balls_gives_spheres():
    """Three boxes blended with fillets of 0.1-0.4 mm meeting in balls: the export's coarse facets of
    a ball also lie on a wide cone, and a ball that became a cone left two flat strips of a fillet
    beside it. The solid has the part's surfaces and volume."""
    part = shapes.shared_part("as_3boxesblend_05.step")
    solid = solid_of_export(part)
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == surface_types(part)
    assert abs(solid.volume / part.Volume - 1) < 5e-4


@needs_freecad
@shapes.needs_shared_data
def test_cad_mesh_of_the_benchmarks_largest_part_gives_its_solid():
    """The benchmark's CAD tessellation of nist_ftc_06 (144 faces). Its bottom face's outline runs
    from fillet arcs of r 3.175 into arcs of r 22.225 tangentially; fitted, each pair's common vertex
    lies a few µm off their exact point of tangency, so the two circles cross a second time 5 µm from
    it, and BRepCheck rejected the face as a self-intersecting wire: the vertex now covers that
    crossing. Three long facets at the tangent borders of the r 22.225 cylinders were left as
    one-facet planes when the reassignment after merging took the rest of their pieces: they join
    the cylinder through their vertices. The solid has the part's faces, surfaces and volume. Its
    faces meet within the distance tolerance, and each meshes: a half cylinder between two planes
    that cut it 0.06 deep has its edges on the crossings its corners lie on (the line of contact,
    half way to the other crossing, left the corners' vertices 0.7 mm wide)."""
    _, layer, solid = benchmark_solid_of_its_part("nist_ftc_06_asme1_rd.stp", "cad")
    assert solid.max_tolerance <= layer.distance_tolerance
    assert_faces_mesh(solid)


@needs_freecad
@shapes.needs_shared_data
def test_cad_mesh_of_a_bolt_gives_its_chamfers_exactly(tmp_path):
    """The benchmark's CAD tessellation of as_bolt-colored-faces: its 45° chamfer is a cone band one
    facet row wide, whose interior vertices lie on one circle (its half-angle was fitted 0.1° off),
    and the six corners of its hexagon head are pieces of one 60° cone whose edges the STEP file
    gives to 1.5e-4, so that each piece's fit tilts by up to 0.2° and puts its apex beyond the
    coaxial tolerance. The band is fitted to all its vertices, and the corners are coaxial where
    they lie (a shift of a 60° cone's axis moves its surface by half of it). The solid has the
    part's faces and its volume within 0.05 % (0.1 % before), in STEP too."""
    _, layer, solid = benchmark_solid_of_its_part("as_bolt-colored-faces.stp", "cad")
    assert_step_round_trip(solid, tmp_path)
    chamfer = max((f for f in layer.features if f["type"] == "cone"), key=lambda f: f["area"])
    assert abs(np.degrees(chamfer["params"]["half_angle"]) - 45) < 1e-3


@needs_freecad
@shapes.needs_shared_data
def test_cad_mesh_of_a_swept_spline_face_gives_its_bspline_face(tmp_path):
    """The benchmark's CAD tessellation of as_ANC101 has a face swept from a spline profile that
    bulges between two planes it is tangent to, 23 facet strips wide. Each few strips fit a cylinder
    (or a plane) as exactly as the export allows, and the face came out as seven cylinders of radii
    6.4 to 15.8 about parallel axes and three planes, each on too few rulings to tell. They are one
    freeform face now, whose swept B-spline closes the solid: the part's faces, surfaces and volume,
    in STEP too (with the part frame taken from its largest plane as fitted, a cylinder band's
    healed seam came back from STEP as a self-intersecting wire). Two crossing cylinders meet in a
    closed intersection curve that is no circle: its vertex lies on the curve's first point, not
    26 mm away where the chain began, and every analytic face meshes."""
    m, layer, solid = benchmark_solid_of_its_part("as_ANC101.stp", "cad")
    assert_faces_mesh(solid)
    assert solid.max_tolerance < 0.01 * np.linalg.norm(m.V.max(axis=0) - m.V.min(axis=0))
    assert_step_round_trip(solid, tmp_path)
    [freeform] = [f for f in layer.features if f["type"] == "freeform"]
    assert np.bincount(m.gt[np.asarray(layer.labels) == freeform["id"]]).argmax() == next(
        i for i, t in enumerate(m.face_types) if t == "SurfaceOfExtrusion")


@needs_freecad
@shapes.needs_shared_data
def test_solid_of_a_part_whose_analytic_faces_do_not_close_keeps_only_sound_tolerances():
    """The benchmark's sculpted as_ANC101 does not close with analytic faces alone. On one edge
    OpenCASCADE's curve-on-surface check returned a distance of 3.5 m for a pcurve on this 0.5 m
    part, which became the tolerance of the edge's vertices; the face holding them was kept, with a
    vertex that covered the part (on a variant of the part the check returned 1e154, and the
    self-intersection check then never returned). No such tolerance is taken now; the faces that
    fail degrade, and the solid closes."""
    m = shapes.benchmark_mesh("as_ANC101.stp", "sculpt")
    solid = idealize.make_solid(idealize.idealize(Mesh(m.V, m.F)))
    assert solid.solid and any(r["kind"] == "faceted" and r["reason"] for r in solid.regions)
    shape = solid.part_shape()
    diagonal = shape.BoundBox.DiagonalLength
    assert shape.Faces and 0 < diagonal < 2 * np.linalg.norm(m.V.max(axis=0) - m.V.min(axis=0))
    assert max(v.Tolerance for v in shape.Vertexes) < diagonal
    assert max(e.Tolerance for e in shape.Edges) < diagonal


@needs_freecad
@shapes.needs_shared_data
@pytest.mark.parametrize("name", ["as_isolated_blends_test_12.stp", "as_customblend_05.step"])
def test_benchmarks_cad_mesh_keeps_slivers_and_narrow_bands(name):
    """The benchmark's CAD tessellations: as_isolated_blends_test_12 has a step of 0.03 mm (two
    triangles), which the plane beside it took whole; as_customblend_05 lies 10 m from the origin
    (its coordinates rounded to 2.5 µm) and has a cylinder one facet high between a plane and a
    fillet of r 0.72, whose first facets the planar split put with the cylinder's, and whose tori
    the B-rep then took for a scan's rounded edges. The solid has the part's surfaces, which meet
    within the distance tolerance and mesh (on as_isolated_blends_test_12 a plane cuts a cylinder
    0.025 deep: see the nist_ftc_06 test)."""
    _, layer, solid = benchmark_solid_of_its_part(name, "cad")
    assert solid.max_tolerance <= layer.distance_tolerance
    assert_faces_mesh(solid)


@needs_freecad
@shapes.needs_shared_data
@pytest.mark.parametrize("name, variant, volume_error", [("occt_Pump_Nut.step", "scan", 1e-2),
                                                         ("as_isolated_blends_test_15.stp", "sculpt", 0.15)])
def test_small_fillets_stay_and_sampled_edges_go(name, variant, volume_error):
    """The benchmark's scan of occt_Pump_Nut has fillets of r 1 on facets of 0.6, two facets wide:
    they stay faces, tangent to their plane and boss (a strip along a sharp edge of a sampled mesh,
    fitted by a cylinder of about a facet's radius, is one facet wide: its facets go back to the
    faces beside it, as on the sculpted as_isolated_blends_test_15). Its chamfer pieces are all
    cones. The solid has the part's surfaces, and its volume within 1 % (the sculpted part's
    undulation changes it by 10 %)."""
    m = shapes.benchmark_mesh(name, variant)
    truth = shapes.benchmark_truth(name)
    solid = idealize.make_solid(idealize.idealize(Mesh(m.V, m.F)))
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == truth["surface_types"]
    assert abs(solid.volume / truth["volume"] - 1) < volume_error


@needs_freecad
@shapes.needs_shared_data
def test_sculpted_box_gives_its_six_faces():
    """The benchmark's sculpted as_box: the undulation bends two of its sides so that each came out
    as two planes 1° apart, with no crease between them, whose common plane strays from the smaller
    piece by more than the distance tolerance. They pass through their border as closely as through
    their own points (no step), so they are one plane: the solid is the box's six planes."""
    m = shapes.benchmark_mesh("as_box.stp", "sculpt")
    truth = shapes.benchmark_truth("as_box.stp")
    solid = idealize.make_solid(idealize.idealize(Mesh(m.V, m.F)))
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == truth["surface_types"] == {"plane": 6}
    assert abs(solid.volume / truth["volume"] - 1) < 2e-2


@needs_freecad
@shapes.needs_shared_data
@pytest.mark.parametrize("name", ["as_3boxesblend_05.step"])
def test_sculpted_parts_whose_ideal_surfaces_the_undulation_moves_give_their_solids(name):
    """The benchmark's sculpted as_3boxesblend_05: every face is segmented correctly, but the
    undulation tilts some fillets' fitted axes by a degree or two, so that their ideal surfaces
    (tangent to the planes and cones beside them) fitted their patches by a little more than the fit
    does, and the fits stayed; they met their tangent neighbours nowhere and the shell did not
    close. On a mesh whose residuals are correlated the ideal surface may deviate by that share of
    the distance tolerance more: the solid has the part's surfaces. (The sculpted occt_Pump_Nut
    closed too, but with a flat whose boundary crossed itself where its line meets a chamfer cone
    at a shallow angle: test_hexagon_flats_that_meet_their_chamfer_at_a_shallow_angle_give_the_solid.)"""
    m = shapes.benchmark_mesh(name, "sculpt")
    truth = shapes.benchmark_truth(name)
    solid = idealize.make_solid(idealize.idealize(Mesh(m.V, m.F)))
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == truth["surface_types"]
    assert abs(solid.volume / truth["volume"] - 1) < 5e-2


@needs_freecad
@shapes.needs_shared_data
def test_faces_at_odd_angles_keep_their_direction():
    """The benchmark's scan of as_isolated_blends_test_12 has vertical faces at 25.4 and 4.8 degrees
    from the part's axes, within the angle tolerance of its ideal directions: snapped, they no longer
    fit their patches, and the fillets tangent to them moved with them, so that their edges crossed.
    Those directions stay as fitted, the others snap: the solid closes, with all nine cylinders."""
    m = shapes.benchmark_mesh("as_isolated_blends_test_12.stp", "scan")
    truth = shapes.benchmark_truth("as_isolated_blends_test_12.stp")
    solid = idealize.make_solid(idealize.idealize(Mesh(m.V, m.F)))
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types["cylinder"] == truth["surface_types"]["cylinder"]
    assert abs(solid.volume / truth["volume"] - 1) < 5e-3


@needs_freecad
@shapes.needs_shared_data
def test_scan_of_a_domed_screw_head_gives_its_solid():
    """The benchmark's scan of occt_mal_vis: the flat outer zone of the head's torus fitted a large
    sphere as well, and stayed a face of its own that could not close. The torus takes it; the solid
    has the part's surfaces and volume."""
    m = shapes.benchmark_mesh("occt_mal_vis.step", "scan")
    part = shapes.shared_part("occt_mal_vis.step")
    solid = idealize.make_solid(idealize.idealize(Mesh(m.V, m.F)))
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == surface_types(part)
    assert abs(solid.volume / part.Volume - 1) < 5e-3


@needs_freecad
@shapes.needs_shared_data
@pytest.mark.parametrize("name", ["mfcad_0-0-0-0-6-23.step", "mfcad_0-0-7-9-14-23.step", "as_boxblend_04.step"])
def test_scans_with_sampled_sharp_edges_give_their_solids(name):
    """The benchmark's scans of prismatic parts: the strips of facets across their sharp edges (a
    cylinder of about a facet's width each) made edges that could not close, and the ball where
    as_boxblend_04's fillets meet was not tangent to them. The solid has the part's faces, and is
    valid in FreeCAD too (the mesh OpenCASCADE made of it for the deviation check, whose polygons its
    checker rejects at corners a vertex tolerance off an edge's curve, does not go with it)."""
    m = shapes.benchmark_mesh(name, "scan")
    part = shapes.shared_part(name)
    solid = idealize.make_solid(idealize.idealize(Mesh(m.V, m.F)))
    assert solid.solid and solid.valid, solid.problems
    assert solid.part_shape().isValid()
    assert solid.surface_types == surface_types(part)
    assert solid.faces == len(part.Faces)
    assert abs(solid.volume / part.Volume - 1) < 5e-3


@needs_freecad
@shapes.needs_shared_data
@pytest.mark.parametrize("name, variant", [("as_bolt-colored-faces.stp", "scan"), ("as_boxblend_04.step", "sculpt"),
                                           ("occt_Pump_Nut.step", "sculpt")])
def test_a_solid_has_no_face_that_a_mesh_cannot_cover(name, variant):
    """Benchmark meshes whose solids had a face that BRepCheck passes but whose boundary crosses
    itself (a scanned hex head's end face, cut by the arcs of its narrow chamfer cone out of order) or
    runs the wrong way round: no mesh covered it, so FreeCAD showed a hole, and its check rejected the
    solid. A solid's mesh covers its whole surface; a face that cannot be covered is reported and
    dropped from the shell."""
    m = shapes.benchmark_mesh(name, variant)
    solid = idealize.make_solid(idealize.idealize(Mesh(m.V, m.F)))
    if solid.solid:  # (at the B-rep benchmark's deflection for its Hausdorff distance chords cover 99.95 %)
        assert covered_area(solid, 2e-4 * m.diag) == pytest.approx(solid.part_shape().Area, rel=2e-3)
    else:
        assert any("no mesh covers it" in message or "wrong way round" in message for _, message in solid.problems)
        assert not solid.closed


def chamfer_cones(layer):
    """The cone features of a hexagon head's chamfer (about 60°)."""
    return [f for f in layer.features if f["type"] == "cone" and abs(np.degrees(f["params"]["half_angle"]) - 60) < 5]


@needs_freecad
@shapes.needs_shared_data
@pytest.mark.parametrize("name, variant, tight", [("as_bolt-colored-faces.stp", "scan", True),
                                                  ("occt_Pump_Nut.step", "sculpt", False)])
def test_hexagon_flats_that_meet_their_chamfer_at_a_shallow_angle_give_the_solid(name, variant, tight):
    """Benchmark meshes of hexagon heads chamfered at their corners. A flat's line on the end face
    meets the chamfer's circle at a shallow angle: the bolt's chamfer is turned to the width across
    the flats (its circle touches each flat's line), the nut's crosses each line twice, 2 mm apart.
    Each corner piece fitted its own cone (the bolt scan's 58-68°, the true one 60°), whose circle
    missed the flats by up to 4 distance tolerances, and each corner, fitted alone from the mesh's
    rounded corner, took either crossing: the faces folded and neither closed. The pieces are one
    60° cone now, and both corners of a flat's line are placed together, in the chain's order: the
    solids have the parts' faces and surfaces (the bolt's flats touch the end face in one point
    each), and every face meshes."""
    m = shapes.benchmark_mesh(name, variant)
    truth = shapes.benchmark_truth(name)
    layer = idealize.idealize(Mesh(m.V, m.F))
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.valid and solid.part_shape().isValid(), solid.problems
    assert solid.surface_types == truth["surface_types"] and solid.faces == truth["faces"]
    assert abs(solid.volume / truth["volume"] - 1) < 1e-2
    assert covered_area(solid, 2e-4 * m.diag) == pytest.approx(solid.part_shape().Area, rel=2e-3)
    cones = chamfer_cones(layer)
    assert len(cones) >= 6 and all(f["params"]["half_angle"] == np.radians(60) for f in cones)
    if tight:  # the flats touch the end face where the surfaces put both corners: no gap to bridge
        assert solid.max_tolerance <= layer.distance_tolerance


@needs_freecad
@pytest.mark.parametrize("seed", [2, 4])
def test_scanned_hexagon_nut_chamfered_to_its_flats_gives_its_solid(seed):
    """A scanned nut (tests/shapes.py) whose 30° chamfers start at the width across the flats, as
    the bolt's above: each chamfer's six corner pieces take one 60° cone, and the solid closes with
    its flats, ends, bore and the twelve pieces. (Seeds 1-4: 1 closes with a second cylinder, 3 does
    not close: a flat's corner on the other chamfer folds.)"""
    part = shapes.hexagon_nut()
    V, F, _, diag = shapes.uniform_remesh(part)
    layer = idealize.idealize(Mesh(shapes.normal_noise(V, F, diag, seed), F))
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == {"cone": 12, "cylinder": 1, "plane": 8}
    assert abs(solid.volume / abs(part.Volume) - 1) < 5e-3
    cones = chamfer_cones(layer)
    assert len(cones) == 12 and len({(f["params"]["apex"], f["params"]["half_angle"]) for f in cones}) == 2


@needs_freecad
@shapes.needs_shared_data
def test_rounds_beside_faces_at_a_non_ideal_angle_keep_the_parts_direction():
    """The benchmark's scan of as_isolated_blends_test_15: a plate whose ends meet its sides at 88°,
    its corners rounded. Snapping turned the ends by 2° onto the part's frame, where they misfit and
    were kept as fitted, but the rounds, placed to touch the turned ends, misfit too and kept their
    own fitted axes, 0.2-1.3° off the plate's normal: the solid bridged gaps of 5 distance
    tolerances. The ends now keep their fitted directions while the rest is idealized about them:
    the rounds' axes are the plate's normal, and the solid's faces meet."""
    m = shapes.benchmark_mesh("as_isolated_blends_test_15.stp", "scan")
    truth = shapes.benchmark_truth("as_isolated_blends_test_15.stp")
    layer = idealize.idealize(Mesh(m.V, m.F))
    plate = max((f for f in layer.features if f["type"] == "plane"), key=lambda f: f["area"])
    for f in layer.features:
        if f["type"] == "cylinder":
            assert abs(np.dot(f["params"]["axis"], plate["params"]["normal"])) > np.cos(np.radians(0.05))
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == truth["surface_types"]
    assert solid.max_tolerance <= layer.distance_tolerance


@needs_freecad
def test_noisy_coarse_cad_export_keeps_its_rounds():
    """A rounded plate with a hole, tessellated coarsely as a CAD exporter does (sides of 20 in
    slivers 0.4 wide) and with noise: its corner radii (5) and hole (8) are below two median edge
    lengths and narrower than one and a half, so the rule for a scanner's sampling strips took them
    for strips, and the sides spanned the corners as planes no mesh could cover (a solid of six
    planes, FreeCAD's check rejecting it). Slivers are no scanner's sampling: the solid has the
    part's eleven faces, all of them covered."""
    part = shapes.bracket_solid()
    V, F, _ = shapes.tessellate_with_faces(part, 0.05)
    V = V + np.random.default_rng(7).normal(scale=0.02, size=V.shape)
    solid = idealize.make_solid(idealize.idealize(Mesh(V, F)))
    assert solid.solid and solid.valid and solid.part_shape().isValid(), solid.problems
    assert solid.surface_types == surface_types(part)
    assert solid.faces == len(part.Faces)
    assert covered_area(solid, 2e-4 * part.BoundBox.DiagonalLength) == pytest.approx(part.Area, rel=2e-3)
    assert abs(solid.volume / part.Volume - 1) < 1e-2


@needs_freecad
def test_noisy_scan_of_a_corner_ball_gives_its_solid():
    """Three fillets meeting in a ball (thesis 4.3, case 2), scanned: on the mesh the fillets also
    touch each other for a few facets beside the ball. Each fillet is tangent to the ball, so where
    two of them and the ball meet is where their circles on the ball cross, and the fillets' short
    common boundary there is no edge. The solid has the part's faces."""
    part = shapes.corner_blend_box()
    V, F, _, diag = shapes.uniform_remesh(part)
    V = shapes.normal_noise(V, F, diag, 2)
    solid = idealize.make_solid(idealize.idealize(Mesh(V, F)))
    assert solid.solid and solid.valid and solid.part_shape().isValid(), solid.problems
    assert solid.surface_types == surface_types(part)
    assert solid.faces == len(part.Faces)
    assert abs(solid.volume / part.Volume - 1) < 5e-3


@needs_freecad
@pytest.mark.parametrize("seed", [0, 1])
def test_noisy_scan_of_a_turned_knob_gives_its_solid(seed):
    """A turned knob, scanned: rim fillets that touch the disc on their torus's outer equator (its v
    seam, where healing left the bands unorientable), a fillet between the disc and a 45° cone (a
    fillet between coaxial surfaces, which the two took half each), and the cone between two tori
    (two bands whose seams differed, so that their common circle was cut differently on each side and
    could not be sewn). The solid has the knob's seven faces and its volume."""
    part = shapes.rounded_knob()
    V, F, _, diag = shapes.uniform_remesh(part)
    V = shapes.normal_noise(V, F, diag, seed)
    solid = idealize.make_solid(idealize.idealize(Mesh(V, F)))
    assert solid.solid and solid.valid and solid.part_shape().isValid(), solid.problems
    assert solid.surface_types == {"plane": 2, "cylinder": 1, "cone": 1, "torus": 3}
    assert abs(solid.volume / part.Volume - 1) < 5e-3


@needs_freecad
def test_cad_export_of_a_slotted_lemon_dome_gives_its_solid():
    """A screw head whose dome is revolved from an arc centred beyond the axis: a lemon, the inner
    part of a spindle torus (major radius < 0 here), which no seeded fit took. The slot cuts across
    the dome and into the 45° cone under it, whose rim then winds round the axis in eight edges with
    two notches: the seam that healing added ran through the face (the slot's walls lean over the
    notch) and left a sliver of it. The solid has the head's eight faces, two of them the dome's
    halves on one lemon, and its volume. (A finer export, 0.1 % of the diagonal, cuts the dome into
    bands one facet row wide, which pair up only through three circles: a ring torus or a lemon
    fits any three, and no lemon is taken from so few.)"""
    part = shapes.slotted_head(dome=True)
    V, F, _ = shapes.cad_export(part, 2e-3 * part.BoundBox.DiagonalLength, 0.5)
    layer = idealize.idealize(Mesh(V, F))
    lemons = [f for f in layer.features if f["type"] == "torus"]
    assert len(lemons) == 2
    for lemon in lemons:
        assert abs(lemon["params"]["major"] + 6) < 1e-3 and abs(lemon["params"]["minor"] - 20) < 1e-3
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.valid and solid.part_shape().isValid(), solid.problems
    assert solid.surface_types == {"plane": 4, "cylinder": 1, "cone": 1, "torus": 2}
    assert abs(solid.volume / part.Volume - 1) < 5e-4
    # Each feature's Part primitive: a lemon's is the spindle torus it lies on.
    from idealize.freecad.solid import primitive_shape
    labels = np.asarray(layer.labels)
    for feature in layer.features:
        shape = primitive_shape(feature, V[np.unique(F[labels == feature["id"]])])
        assert shape is not None and shape.isValid()


@needs_freecad
@pytest.mark.parametrize("seed", [0, 2, 3])
def test_scan_of_a_slotted_flat_head_closes(seed):
    """The flat slotted head, scanned: its cone's rim winds round the axis with two notches, so the
    cone needs a seam that no healing found (the band came out as a sliver), and the shaft below
    shares the circle between them. (Seed 1's scan keeps three narrow strips of the rounded edge
    between shaft and cone as cylinders of their own, and does not close.)"""
    part = shapes.slotted_head(dome=False)
    V, F, _, diag = shapes.uniform_remesh(part)
    V = shapes.normal_noise(V, F, diag, seed)
    solid = idealize.make_solid(idealize.idealize(Mesh(V, F)))
    assert solid.solid and solid.valid and solid.part_shape().isValid(), solid.problems
    assert solid.surface_types == {"plane": 6, "cylinder": 1, "cone": 1}
    assert abs(solid.volume / part.Volume - 1) < 5e-3


@needs_freecad
@shapes.needs_shared_data
def test_cad_export_of_a_slotted_screw_gives_its_solid():
    """The benchmark's CAD export of occt_screw: its head's dome is a lemon cut in halves by the slot
    (it fell into some 180 features of a facet or two), the 45° cone under it winds round the axis
    with two notches, and its point is a cone band one facet wide between two circles (which a
    sphere fits as exactly: a chamfer meets its neighbours at creases). The solid has the part's
    surface types and its volume."""
    m = shapes.benchmark_mesh("occt_screw.step", "cad")
    solid = idealize.make_solid(idealize.idealize(Mesh(m.V, m.F)))
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == {"plane": 4, "cylinder": 1, "cone": 2, "torus": 2}
    truth = shapes.benchmark_truth("occt_screw.step")
    assert solid.surface_types == truth["surface_types"] and solid.faces == truth["faces"]
    assert abs(solid.volume / truth["volume"] - 1) < 5e-4


@needs_freecad
@shapes.needs_shared_data
def test_scan_of_a_slotted_screw_gives_its_solid():
    """The benchmark's scan of occt_screw: each half of its head's dome (a lemon, 9° of arc) fitted a
    free cylinder with a tilted axis as well as the noise allows, and the slot's walls, the part's
    largest planes, tilted the axis of the whole part by 0.3° when their normals set its frame. Each
    half is a lemon about the shank's axis, and the best-determined direction sets the frame: the
    solid has the part's surface types and faces."""
    m = shapes.benchmark_mesh("occt_screw.step", "scan")
    truth = shapes.benchmark_truth("occt_screw.step")
    layer = idealize.idealize(Mesh(m.V, m.F))
    for lemon in (f for f in layer.features if f["type"] == "torus"):
        assert lemon["params"]["major"] < 0 and abs(lemon["params"]["minor"] / 54.87 - 1) < 0.1
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == truth["surface_types"] and solid.faces == truth["faces"]
    assert abs(solid.volume / truth["volume"] - 1) < 2e-2


@needs_freecad
@shapes.needs_shared_data
def test_fitted_edges_of_a_scanned_screw_run_to_their_corners():
    """The benchmark's scan of occt_screw: the walls of its slot meet the lemon of its domed head in a
    curve with no closed form, fitted to the mesh's border, whose end vertices lie 0.3 mm (six
    distance tolerances) short of the corners where the wall, the dome and the cone under it meet.
    Edges that stopped there left gaps that the corners' tolerance bridged, and OpenCASCADE measured
    the solid 1.5 % small. Fitted through the corners, every vertex is within the distance tolerance
    of its edges and the volume within 0.5 % of the part's."""
    m = shapes.benchmark_mesh("occt_screw.step", "scan")
    truth = shapes.benchmark_truth("occt_screw.step")
    layer = idealize.idealize(Mesh(m.V, m.F))
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.valid, solid.problems
    assert solid.max_tolerance <= layer.distance_tolerance
    assert abs(solid.volume / truth["volume"] - 1) < 5e-3


@needs_freecad
@shapes.needs_shared_data
def test_scan_of_blended_boxes_with_torus_corners_gives_its_solid():
    """The benchmark's scan of as_bb_boxblend_03: fillets of r 5.08 meet in quarter tori at the foot
    of vertical fillets and in a horn torus (R = r) at the end of a half-round. The quarter tori fitted
    tilted axes, one passed for a diagonal cylinder, and the horn torus came in two pieces, one fitted
    as a cone: no solid. The tori now lie against the plane and the fillet beside them, and the
    horn torus's cone piece, which that torus explains about as well, joins it: the solid has the
    part's surface types and faces.
    It also has the part's shape, to the benchmark's bounds (volume within 0.5 %, two-sided Hausdorff
    distance within 0.3 % of the diagonal). One fillet, whose flanks the planes beside it took, had
    fitted a radius of 4.46 to what was left of its arc (5.08: volume 0.84 % off); and the strip
    that a fillet took along the plane it rounds ran on past its end into a torus's corner, where
    the edge between them left the part by 0.8 % of the diagonal."""
    m = shapes.benchmark_mesh("as_bb_boxblend_03.stp", "scan")
    truth = shapes.benchmark_truth("as_bb_boxblend_03.stp")
    solid = idealize.make_solid(idealize.idealize(Mesh(m.V, m.F)))
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == truth["surface_types"] and solid.faces == truth["faces"]
    assert abs(solid.volume / truth["volume"] - 1) < 5e-3
    run_brep = shapes.bench_module("run_brep")
    ours = solid.triangulate(run_brep.SAMPLE_DEFLECTION * m.diag)
    distance = run_brep.hausdorff(idealize._native, ours, (truth["V"], truth["F"]))["two_sided"]
    assert distance < 3e-3 * m.diag


@needs_freecad
@shapes.needs_shared_data
def test_scan_of_beaded_washer_keeps_its_bead_tops():
    """The benchmark's scan of nist_ftc_11_asme1_rb: a washer 1.9 thick with a bead of tube r 1.5 on
    each rim, centred on the plane z = 0 where the bead meets the cylinder below it. The two tori are
    of equal radius and concentric; fitted alone, one came out with a larger tube and a lower centre,
    the other the other way round, and the median tube with the mean centre dropped both bead tops by
    0.03 (volume 0.59 % off). Refitted together about their axis with one tube and one centre, and
    with the cylinders they touch (fitted alone 0.012 off), the tops stay where the points are: volume
    within the benchmark's 0.5 %, here 0.2 %; the walls within 0.01, the tube within 1 %."""
    name = "nist_ftc_11_asme1_rb.stp"
    m = shapes.benchmark_mesh(name, "scan")
    truth = shapes.benchmark_truth(name)
    layer = idealize.idealize(Mesh(m.V, m.F))
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == truth["surface_types"]
    assert abs(solid.volume / truth["volume"] - 1) < 2e-3
    tori = [f["params"] for f in layer.features if f["type"] == "torus"]
    assert len(tori) == 2
    for torus in tori:
        assert abs(torus["center"][2] + torus["minor"] - 1.5) < 0.015, torus  # the top of its tube
        assert abs(torus["minor"] / 1.5 - 1) < 0.01, torus
    walls = sorted(f["params"]["radius"] for f in layer.features if f["type"] == "cylinder")
    assert len(walls) == 2 and abs(walls[0] - 16) < 0.01 and abs(walls[1] - 31.5) < 0.01, walls


@needs_freecad
@shapes.needs_shared_data
def test_scan_of_coaxial_blends_closes():
    """The benchmark's scan of as_customblend_05: tori and a cone between cylinders and planes about
    one axis, 10 m from the origin. Its rim tori's bands and the cone between two tori were invalid
    faces; the cone meets its fillet in two crossings 0.6 mm apart (their fits touch
    only nearly), whose fitted edge left both surfaces. The solid closes with a face for every
    feature but the fillet of r 0.52 between a plane and the cone, which the feature layer finds but
    which is 1.35 mesh edges wide, as narrow as a scanner's sampling of a sharp edge: the B-rep gives
    its faces back to the plane and the cone, which meet at the edge. The cone, refitted without the
    fillet's faces, keeps the part's axis (tilted by a degree, its face left the part by 2 mm)."""
    m = shapes.benchmark_mesh("as_customblend_05.step", "scan")
    layer = idealize.idealize(Mesh(m.V, m.F))
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types["torus"] == 4 and solid.surface_types["cone"] == 1
    fillet = [f["id"] for f in layer.features if f["type"] == "torus" and f["params"]["minor"] < 0.6]
    assert len(fillet) == 1
    assert sorted(solid.face_features) == [f["id"] for f in layer.features if f["id"] != fillet[0]]
    truth = shapes.benchmark_truth("as_customblend_05.step")
    assert abs(solid.volume / truth["volume"] - 1) < 5e-3


@needs_freecad
@shapes.needs_shared_data
def test_faces_whose_fitted_edges_stray_from_their_surface_degrade_and_are_named():
    """The benchmark's scan of as_ANC101 does not close: where the surfaces on either side of a
    boundary do not meet near it, the B-spline fitted to the boundary lies off them (its pcurve,
    its projection on the face's surface, ten tolerances or more from it; on the 75k-triangle scan
    of nist_ftc_06 up to 34 mm on a part of 405, checked edge by edge in most of the B-rep's
    time). Such a face does not follow its boundary: it degrades (bounded by the mesh's border, or
    faceted) and the report says why (before, it was kept or failed later without saying why); the
    solid closes. The fitted edges of the analytic faces kept stay within a few tens of the
    distance tolerance."""
    m = shapes.benchmark_mesh("as_ANC101.stp", "scan")
    layer = idealize.idealize(Mesh(m.V, m.F))
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.valid
    assert any("does not follow its boundary" in r["reason"] for r in solid.regions if r["kind"] == "faceted")

    def fitted(edge):
        try:
            return type(edge.Curve).__name__ == "BSplineCurve"
        except TypeError:  # a degenerate edge
            return False

    tolerances = [e.Tolerance for e in solid.part_shape().Edges if fitted(e)]
    assert not tolerances or max(tolerances) < 30 * layer.distance_tolerance


@needs_freecad
@shapes.needs_shared_data
def test_degraded_faces_pass_the_boolean_checks_and_do_not_depend_on_thread_timing():
    """The benchmark's scan of as_3boxesblend_05 does not close (nor did as_bb_boxblend_03's, which this
    test used until it closed). Some of its faces are bounded by edges that cross each other or leave
    the surface, or by a boundary running the wrong way round (on the scan of as_circular_blend_01,
    before it closed, a torus face of negative area): BRepCheck passed them, and OpenCASCADE's mesher
    never returned on such a torus face (the deviation check hung). Such faces are left out and
    named; now they degrade, and the solid closes. Edges are made and faces checked on two threads,
    each taking the next when free: the edges, what degrades and what is named must not depend on
    which finishes first."""
    m = shapes.benchmark_mesh("as_3boxesblend_05.step", "scan")
    layer = idealize.idealize(Mesh(m.V, m.F))
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.valid
    for _ in range(3):
        again = idealize.make_solid(layer)
        assert again.brep_string() == solid.brep_string() and again.problems == solid.problems
        assert again._brep.edges == solid._brep.edges and again.regions == solid.regions
    shape = solid.part_shape()
    for face in shape.Faces:
        if type(face.Surface).__name__ != "Plane":
            face.check(True)  # raises on what the boolean operations' analyzer finds
        assert face.Area > 0
    assert np.isfinite(solid.max_deviation)
    assert any("not valid" in r["reason"] for r in solid.regions if r["kind"] == "faceted"), solid.regions


@needs_freecad
@shapes.needs_shared_data
def test_scanned_round_along_a_circle_beside_its_plane_gives_the_solid():
    """The benchmark's scan of as_circular_blend_01: a round of r 13.49 along a circle of 28.04 runs
    tangentially into the plane under it, and the histogram joins both in one patch. Cylinders grown
    in it fitted sectors of the round and cut the plane into three; the first that grew on as a
    torus came late. Split again with that torus grown first, the patch is the plane and the round:
    the solid closes with the part's surfaces (before: no solid, 9 features failed)."""
    m = shapes.benchmark_mesh("as_circular_blend_01.step", "scan")
    truth = shapes.benchmark_truth("as_circular_blend_01.step")
    solid = idealize.make_solid(idealize.idealize(Mesh(m.V, m.F)))
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == truth["surface_types"]
    assert abs(solid.volume / truth["volume"] - 1) < 5e-3


@needs_freecad
@pytest.mark.parametrize("seed", [1, 3, 6])
def test_noisy_scan_of_a_bent_rod_gives_its_solid(seed):
    """A rod of r 5 bent about a radius of 15 between two straight runs (shapes.bent_rod), scanned
    with noise: each run touches the bend along the meridian circle through the point where its
    axis touches the torus's centre circle. That circle is the edge (the general intersection of
    the nearly tangent surfaces left all three seeds without a solid)."""
    part = shapes.bent_rod()
    V, F, _, diag = shapes.uniform_remesh(part)
    V = shapes.normal_noise(V, F, diag, seed)
    solid = idealize.make_solid(idealize.idealize(Mesh(V, F)))
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == {"plane": 2, "cylinder": 2, "torus": 1}
    assert abs(solid.volume / part.Volume - 1) < 5e-3, solid.volume


@needs_freecad
@shapes.needs_shared_data
@pytest.mark.parametrize("name", ["as_azv_clamp.step", "occt_mal_tige.step"])
def test_scanned_fillets_meet_their_planes_at_the_corners(name):
    """The benchmark's scans of a clamp and a rod with flats: where a fillet or a rod runs
    tangentially into a plane and both end at a third face, the corner lies on their line of
    contact. From the three surfaces alone, least squares left it where the noisy mesh put it,
    across the zone where the two are close: 2 and 4 mm off the edge between them, which its vertex
    tolerance then bridged (9 and 15 times the distance tolerance) and across which a mesher may
    leave a face out. The solid has the part's surfaces, and its faces meet within the distance tolerance."""
    m = shapes.benchmark_mesh(name, "scan")
    layer = idealize.idealize(Mesh(m.V, m.F))
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.valid, solid.problems
    assert solid.surface_types == shapes.benchmark_truth(name)["surface_types"]
    assert solid.max_tolerance <= layer.distance_tolerance
    assert_faces_mesh(solid)


@needs_freecad
def test_a_region_no_surface_explains_becomes_facets_and_the_solid_closes():
    """Graceful degradation: the box's hole marked freeform gets no fitted surface (a tube is no
    height field, and a profile that wraps round an axis gets no B-spline), and no feature explains
    its region. It becomes its own triangles as planar facets, the planes around it stay analytic,
    bounded by the mesh's polyline there, and the solid closes with the mesh's volume: no face is
    dropped (before: the hole had no face and the shell did not close)."""
    import copy
    layer, solid = solid_of(box_with_hole(), tolerance=0.05)
    assert solid.solid and all(r["kind"] == "analytic" for r in solid.regions)
    assert solid.analytic_area_fraction == pytest.approx(1.0)
    broken = copy.copy(layer)
    broken.features = copy.deepcopy(layer.features)
    hole = next(f for f in broken.features if f["type"] == "cylinder")
    hole["type"], hole["params"] = "freeform", {}
    degraded = idealize.make_solid(broken)
    assert degraded.solid and degraded.valid and degraded.closed, degraded.problems
    kinds = {r["feature"]: r["kind"] for r in degraded.regions}
    assert kinds[hole["id"]] == "faceted"
    assert sum(k == "analytic" for k in kinds.values()) == 6
    assert "no surface explains it" in next(r for r in degraded.regions if r["feature"] == hole["id"])["reason"]
    V, F = layer.mesh.vertices, layer.oriented_faces
    mesh_volume = np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])).sum() / 6
    assert degraded.volume == pytest.approx(mesh_volume, rel=1e-3)
    assert 0.5 < degraded.analytic_area_fraction < 1.0
    assert degraded.surface_types["plane"] == 6 and degraded.surface_types["facet"] > 16
    report = degraded.report()
    assert report["faces_by_kind"] == {"analytic": 6, "bspline": 0, "faceted": 1}
    assert report["faceted"][0]["feature"] == hole["id"]


@needs_freecad
def test_two_bodies_in_one_mesh_give_a_compound_of_two_solids():
    """A mesh of two separate boxes (an assembly exported as one file) is two bodies: each closes
    into a solid of its own, and their volumes add up."""
    FreeCAD, Part, _ = shapes.freecad()
    pair = Part.makeBox(10, 10, 10).fuse(Part.makeBox(5, 5, 5, FreeCAD.Vector(20, 0, 0)))
    layer, solid = solid_of(pair, tolerance=0.05)
    assert solid.solid and solid.valid, solid.problems
    assert solid.volume == pytest.approx(1000 + 125, rel=1e-6)
    assert solid.part_shape().ShapeType == "Compound" and len(solid.part_shape().Solids) == 2


@needs_freecad
@shapes.needs_shared_data
@pytest.mark.parametrize("name", ["casting.stl", "fandisk.obj", "fandisk_noisy0.1.off", "joint.stl",
                                  "abc_00000050_trimesh_000.stl", "block.stl", "MachinedPart2.stl",
                                  "occt_TR12J_OCC.stl"])
def test_real_closed_meshes_give_valid_solids(name):
    """Every closed real mesh of the test data, nobody here wrote (CAD tessellations, remeshed CAD
    parts with a thousand sliver features, a noisy one, and an assembly of three parts; some have
    edges where two sheets touch, which is no border of the mesh, others regions that no feature
    explains): each gives a valid closed solid, with the mesh's volume within the area times the
    distance tolerance, the mesh's Euler characteristic, and says which regions are faceted and
    why."""
    mesh = idealize.load_mesh(str(shapes.SHARED_STEP.parent / "mesh" / name))
    layer = idealize.idealize(mesh)
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.valid and solid.closed, solid.problems[:5]
    V, F = mesh.vertices, layer.oriented_faces
    mesh_volume = abs(np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])).sum() / 6)
    area = shapes.triangle_areas(V, F).sum()
    assert abs(solid.volume - mesh_volume) <= area * layer.distance_tolerance
    assert solid.euler["solid"] == solid.euler["mesh"]
    assert all(r["reason"] for r in solid.regions if r["kind"] == "faceted")
    assert 0.0 <= solid.analytic_area_fraction <= 1.0


@needs_freecad
def test_the_brep_reads_the_layers_mesh_kind_and_angle_tolerance():
    """The B-rep takes the feature layer's decision about the mesh. On a scan, rounds narrower than
    the sampling (here two fillets of 0.6 on edges of about 0.8) are strips that go back to the
    planes beside them; told the mesh is an exact tessellation, it keeps every feature's face. The
    layer's angle tolerance reaches it too, and bad values are refused with a message."""
    from idealize._loader import native
    _, Part, _ = shapes.freecad()
    box = Part.makeBox(40, 30, 20)
    box = box.makeFillet(0.6, [box.Edges[0], box.Edges[2]])
    V, F, _, diagonal = shapes.uniform_remesh(box, 20000)
    V = shapes.normal_noise(V, F, diagonal, seed=2)
    layer = idealize.idealize(idealize.Mesh(V, F), angle_tolerance=4.0)
    assert layer.mesh_kind == "measured surface" and layer.angle_tolerance == 4.0
    assert layer.type_counts() == {"plane": 6, "cylinder": 2}
    assert dict(idealize.make_solid(layer).surface_types) == {"plane": 6}
    args = (V, layer.oriented_faces, np.asarray(layer.labels, np.int32), [f["type"] for f in layer.features],
            [dict(f["params"]) for f in layer.features], layer.distance_tolerance)
    exact = native.build_brep(*args, mesh_kind="exact tessellation")
    assert exact.solid and dict(exact.surface_types) == {"plane": 6, "cylinder": 2}
    with pytest.raises(ValueError, match="mesh_kind"):
        native.build_brep(*args, mesh_kind="scan")
    with pytest.raises(ValueError, match="angle tolerance"):
        native.build_brep(*args, angle_tolerance=0.0)
