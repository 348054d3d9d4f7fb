"""Feature-based editing, part 1 (issue 51): push/pull, parameters and moves on exact layers of
generated parts, with propagation through the feature graph and adaptive remeshing."""
import numpy as np
import pytest

import idealize
import shapes
from idealize import edit

needs_freecad = pytest.mark.skipif(shapes.freecad() is None, reason="FreeCAD is not installed")


_layer = shapes.quality_layer


@pytest.fixture(scope="module")
def plate():
    """60 x 40 x 20 with two through holes (r 6 and r 4)."""
    FreeCAD, Part, _ = shapes.freecad()
    solid = Part.makeBox(60, 40, 20).cut(Part.makeCylinder(6, 20, FreeCAD.Vector(20, 20, 0)))
    return _layer(solid.cut(Part.makeCylinder(4, 20, FreeCAD.Vector(45, 20, 0))))


@pytest.fixture(scope="module")
def filleted():
    """60 x 40 x 20 with its four top edges rounded (r 4)."""
    _, Part, _ = shapes.freecad()
    box = Part.makeBox(60, 40, 20)
    return _layer(box.makeFillet(4, [e for e in box.Edges if min(v.Point.z for v in e.Vertexes) > 19]))


@pytest.fixture(scope="module")
def bracket():
    return _layer(shapes.bracket_solid())


def plane_at(layer, normal, height):
    """The plane feature whose normal is +-`normal` and which passes at `height` along it."""
    normal = np.asarray(normal, float)
    for f in layer.features:
        if f["type"] == "plane" and abs(np.dot(f["params"]["normal"], normal)) > 0.999 \
                and abs(np.dot(f["params"]["point"], normal) - height) < 1e-6:
            return f["id"]
    raise AssertionError("no plane at %s along %s" % (height, normal))


def cylinders(layer, radius):
    return [f["id"] for f in layer.features if f["type"] == "cylinder" and abs(f["params"]["radius"] - radius) < 1e-3]


def check_exact(layer, solid_faces):
    """Every vertex on its features, the mesh closed and manifold, the solid valid with its faces."""
    diagonal = np.linalg.norm(np.ptp(layer.mesh.vertices, axis=0))
    assert layer.deviation["max"] <= 1e-6 * diagonal
    check = idealize.segment(layer.mesh).mesh_check
    assert check["boundary_edges"] == 0 and check["nonmanifold_edges"] == 0 and check["shells"] == 1
    solid = idealize.make_solid(layer)
    assert solid.solid and not solid.problems
    assert solid.faces == solid_faces
    return solid


@needs_freecad
@pytest.mark.parametrize("distance", [5.0, -5.0, 12.5])
def test_push_pull_plane_changes_the_volume_by_area_times_distance(plate, distance):
    layer, part = plate
    top = plane_at(layer, (0, 0, 1), 20)
    before = (layer.idealized_vertices.copy(), np.array(layer.labels).copy(), [dict(f) for f in layer.features])
    edited = edit.push_pull(layer, top, distance)
    section = part.Volume / 20.0
    solid = check_exact(edited, len(part.Faces))
    assert solid.volume == pytest.approx(part.Volume + section * distance, rel=1e-3)
    assert edited.features[top]["params"]["point"][2] == pytest.approx(20 + distance, abs=1e-9)
    assert edited.changed == [top]
    # The input layer is untouched.
    assert np.array_equal(layer.idealized_vertices, before[0]) and np.array_equal(layer.labels, before[1])
    assert layer.features == before[2]


@needs_freecad
def test_pulled_top_carries_its_fillets_tangent_with_their_radius(filleted):
    layer, part = filleted
    top = plane_at(layer, (0, 0, 1), 20)
    fillets = cylinders(layer, 4.0)
    assert len(fillets) == 4
    edited = edit.push_pull(layer, top, 3.0)
    assert sorted(edited.changed) == sorted([top] + fillets)
    solid = check_exact(edited, len(part.Faces))
    assert solid.volume == pytest.approx(part.Volume + 60 * 40 * 3.0, rel=1e-3)
    for f in fillets:
        p, p0 = edited.features[f]["params"], layer.features[f]["params"]
        assert p["radius"] == p0["radius"]
        # Still tangent to the top: horizontal, its axis a radius below the top; moved straight up.
        assert abs(p["axis"][2]) < 1e-12
        assert p["point"][2] == pytest.approx(23.0 - p["radius"], abs=1e-9)
        assert np.allclose(np.array(p["point"]) - p0["point"], (0, 0, 3.0), atol=1e-9)


@needs_freecad
def test_pushed_down_past_the_bottom_is_refused_naming_a_feature(plate):
    layer, _ = plate
    top = plane_at(layer, (0, 0, 1), 20)
    with pytest.raises(edit.EditConflict, match=r"feature \d+"):
        edit.push_pull(layer, top, -25.0)


@needs_freecad
def test_hole_radius_changes_the_volume_exactly(plate):
    layer, part = plate
    hole = cylinders(layer, 6.0)[0]
    edited = edit.set_parameter(layer, hole, "radius", 7.5)
    solid = check_exact(edited, len(part.Faces))
    assert solid.volume == pytest.approx(part.Volume - np.pi * (7.5 ** 2 - 6 ** 2) * 20, rel=1e-3)
    assert edited.features[hole]["params"]["radius"] == pytest.approx(7.5)


@needs_freecad
def test_moved_hole_keeps_the_volume_and_moves_by_the_translation(plate):
    layer, part = plate
    hole = cylinders(layer, 4.0)[0]
    edited = edit.move(layer, [hole], (-3.0, 4.0, 0.0))
    solid = check_exact(edited, len(part.Faces))
    assert solid.volume == pytest.approx(part.Volume, rel=1e-3)
    moved = np.array(edited.features[hole]["params"]["point"]) - np.array(layer.features[hole]["params"]["point"])
    assert np.allclose(moved[:2], (-3.0, 4.0), atol=1e-9)


@needs_freecad
def test_equal_radii_change_together_unless_the_relation_is_broken(bracket):
    layer, part = bracket
    fillets = cylinders(layer, 5.0)
    assert len(fillets) == 4
    together = edit.set_parameter(layer, fillets[0], "radius", 6.0)
    assert sorted(together.changed) == sorted(fillets)
    check_exact(together, len(part.Faces))
    alone = edit.set_parameter(layer, fillets[0], "radius", 6.0, keep={"equal_radius": False})
    assert alone.changed == [fillets[0]]
    assert [alone.features[f]["params"]["radius"] for f in fillets[1:]] == pytest.approx([5.0] * 3)
    # Still tangent to both walls it joins: its axis a radius inside each.
    check_exact(alone, len(part.Faces))


@needs_freecad
def test_a_fillet_larger_than_its_wall_is_refused(filleted):
    layer, _ = filleted
    fillet = cylinders(layer, 4.0)[0]
    with pytest.raises(edit.EditConflict, match="feature %d" % fillet):
        edit.set_parameter(layer, fillet, "radius", 30.0, keep={"equal_radius": False})


@needs_freecad
def test_parameters_that_a_feature_lacks_are_refused(plate):
    layer, _ = plate
    top = plane_at(layer, (0, 0, 1), 20)
    with pytest.raises(ValueError, match="plane has no parameter 'radius'"):
        edit.set_parameter(layer, top, "radius", 3.0)
    with pytest.raises(ValueError, match="no feature"):
        edit.push_pull(layer, 999, 1.0)
    with pytest.raises(ValueError, match="unknown relation"):
        edit.push_pull(layer, top, 1.0, keep={"parallel_universe": True})
    hole = cylinders(layer, 6.0)[0]
    with pytest.raises(ValueError, match="not positive"):
        edit.set_parameter(layer, hole, "radius", -1.0)


@needs_freecad
def test_successive_large_edits_keep_the_triangles_well_shaped(plate):
    layer, part = plate
    top = plane_at(layer, (0, 0, 1), 20)
    hole = cylinders(layer, 4.0)[0]
    edges = np.linalg.norm(layer.mesh.vertices[layer.mesh.faces] - np.roll(layer.mesh.vertices[layer.mesh.faces], 1, axis=1), axis=2)
    current = layer
    for step in range(6):
        current = edit.push_pull(current, top, 10.0 if step % 2 == 0 else -10.0)
        current = edit.move(current, [hole], (0.0, 4.0 if step % 2 == 0 else -4.0, 0.0))
    check_exact(current, len(part.Faces))
    V, F = current.mesh.vertices, current.mesh.faces
    assert (shapes.min_angles(V, F) >= 20).mean() >= 0.97
    after = np.linalg.norm(V[F] - np.roll(V[F], 1, axis=1), axis=2)
    assert after.mean() == pytest.approx(edges.mean(), rel=0.2)


@needs_freecad
def test_a_repeated_triangle_of_the_input_does_not_stop_an_edit():
    """The mesh check sets a repeated triangle aside; the edit leaves it out, and remeshes."""
    _, Part, _ = shapes.freecad()
    V, F = shapes.quality_mesh(Part.makeBox(60, 40, 20), 4.0)
    layer = idealize.idealize(idealize.Mesh(V, np.vstack([F, F[:1]])))
    assert layer.mesh_check["duplicate_removed"] == 1
    edited = edit.push_pull(layer, plane_at(layer, (0, 0, 1), 20), 5.0)
    assert edited.remeshing_problem is None
    check_exact(edited, 6)
    assert idealize.make_solid(edited).volume == pytest.approx(60 * 40 * 25, rel=1e-6)


def run_apart(tmp_path, body, timeout):
    """Runs the script `body` (which reads REPO, the repository's path) in a process of its own, so
    that a crash fails the test instead of ending the test run; its CompletedProcess."""
    import os
    import subprocess
    import sys
    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    script = tmp_path / "apart.py"
    script.write_text("REPO = %r\n" % repo + body)
    return subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=timeout)


CORNER_BALL_EDITS = r'''
import sys
sys.path[:0] = [REPO, REPO + "/tests"]
import shapes
_, Part, _ = shapes.freecad()
from idealize import edit
box = Part.makeBox(60, 40, 30)
layer, _ = shapes.quality_layer(box.makeFillet(5, box.Edges))
outcomes = []
for plane in [f["id"] for f in layer.features if f["type"] == "plane"]:
    for distance in (10.0, -10.0, 60.0):
        try:
            edit.push_pull(layer, plane, distance)
            outcomes.append("done")
        except edit.EditConflict:
            outcomes.append("refused")
for fillet in [f["id"] for f in layer.features if f["type"] == "cylinder"][:2]:
    try:
        edit.set_parameter(layer, fillet, "radius", 6.0, keep={"equal_radius": False})
        outcomes.append("done")
    except edit.EditConflict:
        outcomes.append("refused")
print(len(outcomes), "edits:", sorted(set(outcomes)))
'''


@needs_freecad
def test_editing_a_box_with_corner_balls_never_crashes(tmp_path):
    """Regression: pushing a plane beside a corner ball (and a fillet's radius alone) killed the
    process in CGAL's tangential relaxation, reading past its arrays at a vertex whose triangles were
    all degenerate. Every edit must end in a result or an EditConflict; run apart, so that a crash is
    a failure here and not the end of the test run."""
    run = run_apart(tmp_path, CORNER_BALL_EDITS, timeout=1200)
    assert run.returncode == 0, "the edits crashed (exit %d): %s" % (run.returncode, run.stderr[-2000:])
    assert run.stdout.startswith("20 edits:")


REAL_MESH_PUSHES = r'''
import resource, sys
sys.path[:0] = [REPO, REPO + "/tests"]
# A runaway remeshing grew past 20 GB here; 3 GB is many times what this 13k-triangle mesh needs.
resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))
import numpy as np
import idealize
from idealize import edit
layer = idealize.idealize(idealize.load_mesh(MESH))
V0 = np.asarray(layer.mesh.vertices)
outcomes = []
for f in layer.features:
    if f["type"] not in ("plane", "cylinder"):
        continue
    for distance in (1.0, -1.0):
        try:
            V = np.asarray(edit.push_pull(layer, f["id"], distance).mesh.vertices)
        except edit.EditConflict:
            outcomes.append("refused")
            continue
        # Nothing of the part moves further out than the push (and the mesh's distance from its
        # surfaces, which the vertices put onto them lose).
        grown = max((V0.min(0) - V.min(0)).max(), (V.max(0) - V0.max(0)).max())
        assert grown <= abs(distance) + layer.distance_tolerance, (f["id"], distance, grown)
        outcomes.append("done")
print(len(outcomes), "edits:", sorted(set(outcomes)))
'''


@needs_freecad
@shapes.needs_shared_data
def test_pushing_a_real_mesh_never_runs_away(tmp_path):
    """Regression: on a real mesh, pushing a cylinder sent the border of two nearly tangent
    surfaces (a plane and a cylinder that were not a tangent pair) to where they cross, thousands of
    units away; remeshing that took all memory. Every push of a plane or cylinder by +-1 must end in a
    result no larger than the push allows, or an EditConflict, within a bounded memory."""
    mesh = shapes.SHARED_STEP.parent / "mesh" / "fandisk.obj"
    run = run_apart(tmp_path, "MESH = %r\n" % str(mesh) + REAL_MESH_PUSHES, timeout=600)
    assert run.returncode == 0, "the edits failed (exit %d): %s" % (run.returncode, run.stderr[-2000:])
    assert " edits:" in run.stdout


@pytest.fixture(scope="module")
def corner_balls():
    """60 x 40 x 30 with every edge rounded (r 5): twelve fillets meeting in eight corner balls."""
    _, Part, _ = shapes.freecad()
    box = Part.makeBox(60, 40, 30)
    return _layer(box.makeFillet(5, box.Edges))


def rounded_box(x, y, z, radius):
    _, Part, _ = shapes.freecad()
    box = Part.makeBox(x, y, z)
    return box.makeFillet(radius, box.Edges)


@needs_freecad
@pytest.mark.parametrize("distance", [10.0, -10.0, 60.0])
def test_a_plane_beside_corner_balls_pushes_exactly(corner_balls, distance):
    """The balls roll with their fillets (thesis Fig 6.9): the solid is the box built longer."""
    layer, part = corner_balls
    side = plane_at(layer, (1, 0, 0), 60)
    edited = edit.push_pull(layer, side, distance)
    assert not edited.remeshing_problem
    solid = check_exact(edited, len(part.Faces))
    assert solid.volume == pytest.approx(rounded_box(60 + distance, 40, 30, 5).Volume, rel=1e-6)
    balls = [f for f in edited.features if f["type"] == "sphere"]
    assert len(balls) == 8 and all(f["params"]["radius"] == pytest.approx(5.0) for f in balls)
    assert sorted(round(f["params"]["center"][0], 6) for f in balls) == [5.0] * 4 + [55.0 + distance] * 4


@needs_freecad
@pytest.mark.parametrize("radius", [4.0, 6.0])
def test_equal_fillets_take_their_corner_balls_along(corner_balls, radius):
    layer, part = corner_balls
    fillet = cylinders(layer, 5.0)[0]
    edited = edit.set_parameter(layer, fillet, "radius", radius)
    solid = check_exact(edited, len(part.Faces))
    assert solid.volume == pytest.approx(rounded_box(60, 40, 30, radius).Volume, rel=1e-6)
    assert all(f["params"]["radius"] == pytest.approx(radius) for f in edited.features if f["type"] != "plane")


@needs_freecad
def test_one_fillet_alone_cannot_keep_its_corner_balls(corner_balls):
    layer, _ = corner_balls
    fillet = cylinders(layer, 5.0)[0]
    with pytest.raises(edit.EditConflict, match="sphere"):
        edit.set_parameter(layer, fillet, "radius", 6.0, keep={"equal_radius": False})


@needs_freecad
def test_pushing_a_hole_shut_is_a_conflict_not_a_bad_argument(plate):
    """A push/pull that would shrink a radius past nothing is an edit no shape satisfies."""
    layer, _ = plate
    hole = cylinders(layer, 4.0)[0]
    outcomes = []
    for distance in (5.0, -5.0):  # one of them shrinks the hole past its radius of 4
        try:
            edit.push_pull(layer, hole, distance)
            outcomes.append("done")
        except edit.EditConflict as conflict:
            outcomes.append("radius" if "radius would be" in str(conflict) else "conflict")
    assert "radius" in outcomes
    with pytest.raises(ValueError):
        edit.set_parameter(layer, hole, "radius", -1.0)
