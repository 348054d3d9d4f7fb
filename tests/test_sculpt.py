"""Sculpting brushes with dynamic topology (issue 53): each brush does what it says inside its
radius and nothing outside it; random strokes keep the mesh closed, manifold, consistently oriented
and well shaped; bad input is refused with a message."""
import numpy as np
import pytest

import idealize
import shapes
from idealize import sculpt

RADIUS = 10.0


@pytest.fixture(scope="module")
def sphere():
    V, F = shapes.icosphere(RADIUS, 4)  # 5,120 faces, edges about 0.8
    return idealize.Mesh(V, F)


def topology(mesh):
    """(edges with other than two faces, directed edges used twice, Euler characteristic)."""
    F = mesh.faces
    directed = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    _, counts = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    repeated = len(directed) - len(np.unique(directed, axis=0))
    used = np.unique(F)
    return int(np.sum(counts != 2)), int(repeated), len(used) - len(counts) + len(F)


def view_at(point):
    """A stroke point on the sphere and the view direction there (from outside, at the centre)."""
    point = np.asarray(point, float)
    return point / np.linalg.norm(point) * RADIUS, -point / np.linalg.norm(point)


def stroke_over(a, b, n=5):
    """A stroke along the great circle from a to b (unit directions), with its view directions."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    points = [view_at((1 - t) * a + t * b) for t in np.linspace(0, 1, n)]
    return np.array([p for p, _ in points]), np.array([d for _, d in points])


def untouched(before, after, centre, reach):
    """Whether every vertex of `before` farther than `reach` from `centre` is still a vertex of
    `after`, at exactly the same place."""
    far = before.vertices[np.linalg.norm(before.vertices - centre, axis=1) > reach]
    kept = {tuple(v) for v in after.vertices}
    return all(tuple(v) in kept for v in far)


def test_draw_raises_the_surface_under_the_brush_and_nothing_else(sphere):
    points, directions = stroke_over([0, 0, 1], [0.3, 0, 1])
    vertices = sphere.vertices.copy()
    mesh, modified = sculpt.stroke(sphere, "draw", points, directions, radius=3.0, strength=0.5)
    assert np.array_equal(sphere.vertices, vertices)  # the input is not modified
    radii = np.linalg.norm(mesh.vertices, axis=1)
    assert radii.max() > RADIUS + 0.2
    # Beyond the radius from every stroke point nothing moved (vertices there are the same).
    assert untouched(sphere, mesh, points[0], 3.0 + np.linalg.norm(points[-1] - points[0]))
    assert 0 < modified.sum() < len(mesh.faces) / 4
    dug, _ = sculpt.stroke(sphere, "draw", points, directions, radius=3.0, strength=-0.5)
    assert np.linalg.norm(dug.vertices, axis=1).min() < RADIUS - 0.2


def test_flatten_takes_a_bump_down_and_smooth_evens_out_noise(sphere):
    points, directions = stroke_over([0, 0, 1], [0.2, 0, 1])
    sculptor = sculpt.Sculptor(sphere)
    for _ in range(3):
        sculptor.stroke("draw", points, directions, radius=3.0, strength=1.0)
    bump = np.linalg.norm(sculptor.mesh().vertices, axis=1).max() - RADIUS
    across = stroke_over([-0.4, 0, 1], [0.6, 0, 1], 9)  # over the bump, one radius beyond each side
    for _ in range(3):
        sculptor.stroke("flatten", *across, radius=4.0, strength=1.0)
    assert np.linalg.norm(sculptor.mesh().vertices, axis=1).max() - RADIUS < 0.5 * bump

    rng = np.random.default_rng(3)
    V = sphere.vertices + rng.normal(0, 0.05, sphere.vertices.shape)
    noisy = idealize.Mesh(V, sphere.faces)
    near = np.linalg.norm(V - [0, 0, RADIUS], axis=1) < 2.0
    before = np.std(np.linalg.norm(V[near], axis=1))
    smoothed, _ = sculpt.stroke(noisy, "smooth", *stroke_over([0, 0, 1], [0.01, 0, 1], 2), radius=4.0, strength=1.0)
    W = smoothed.vertices
    after = np.std(np.linalg.norm(W[np.linalg.norm(W - [0, 0, RADIUS], axis=1) < 2.0], axis=1))
    assert after < 0.5 * before


def test_inflate_grows_pinch_draws_together_grab_follows(sphere):
    def volume(mesh):
        V, F = mesh.vertices, mesh.faces
        return np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])).sum() / 6

    points, directions = stroke_over([0, 0, 1], [0.3, 0, 1])
    inflated, _ = sculpt.stroke(sphere, "inflate", points, directions, radius=3.0, strength=0.5)
    assert volume(inflated) > volume(sphere) + 1.0
    # Pinch along a line: the vertices near it close in on it (their distance to the stroke's
    # plane y = 0 shrinks).
    band = lambda V: np.abs(V[(np.abs(V[:, 1]) < 2.0) & (V[:, 0] > 0.0) & (V[:, 0] < 2.5) & (V[:, 2] > 8.5), 1]).mean()
    pinched, _ = sculpt.stroke(sphere, "pinch", points, directions, radius=3.0, strength=1.0)
    assert band(pinched.vertices) < 0.9 * band(sphere.vertices)
    creased, _ = sculpt.stroke(sphere, "crease", points, directions, radius=3.0, strength=1.0)
    assert volume(creased) < volume(sphere)
    # Grab: the vertex under the first point moves with the stroke.
    top = np.argmax(sphere.vertices[:, 2])
    start = sphere.vertices[top]
    grabbed, _ = sculpt.stroke(sphere, "grab", [start, start + [0, 0, 2.0]], None, radius=3.0, strength=1.0)
    # (The dynamic topology's relaxation then slides vertices along the surface, not off it.)
    assert grabbed.vertices[:, 2].max() == pytest.approx(start[2] + 2.0, abs=0.05)


def test_random_strokes_keep_the_mesh_closed_manifold_and_well_shaped(sphere):
    rng = np.random.default_rng(7)
    sculptor = sculpt.Sculptor(sphere)
    for i in range(200):
        a = rng.normal(size=3)
        b = a / np.linalg.norm(a) + rng.normal(0, 0.2, 3)
        points, directions = stroke_over(a / np.linalg.norm(a), b, 4)
        brush = sculpt.BRUSHES[i % len(sculpt.BRUSHES)]
        if brush == "grab":
            points = [points[0], points[0] + rng.normal(0, 0.5, 3)]
            directions = None
        sculptor.stroke(brush, points, directions, radius=rng.uniform(1.5, 4.0),
                        strength=rng.uniform(0.2, 1.0) * rng.choice([1, -1]))
    mesh, modified = sculptor.mesh(), sculptor.modified()
    assert topology(mesh) == (0, 0, 2)  # closed, oriented, still a sphere
    angles = shapes.min_angles(mesh.vertices, mesh.faces)
    assert modified.mean() > 0.5
    assert np.mean(angles >= 20.0) >= 0.99
    assert np.all(np.isfinite(mesh.vertices))


def test_the_same_strokes_give_the_same_mesh(sphere):
    points, directions = stroke_over([0, 1, 0], [0, 1, 0.4])
    first = [sculpt.stroke(sphere, brush, points, directions, radius=2.5, strength=0.7)[0] for brush in ("draw", "pinch")]
    again = [sculpt.stroke(sphere, brush, points, directions, radius=2.5, strength=0.7)[0] for brush in ("draw", "pinch")]
    for a, b in zip(first, again):
        assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)


def test_a_stroke_dab_by_dab_as_the_pointer_moves_is_the_stroke_at_once(sphere):
    # The 3D view sculpts while the pointer moves; the document replays the stroke at once: both
    # must make the same mesh, to the bit, for every brush (a grab included).
    points, directions = stroke_over([0, 0.2, 1], [0.5, 0.2, 1], n=9)
    for brush in sculpt.BRUSHES:
        at_once = sculpt.Sculptor(sphere)
        report = at_once.stroke(brush, points, directions, radius=2.5, strength=0.6)
        live = sculpt.Sculptor(sphere)
        live.begin(brush, points[0], directions[0], radius=2.5, strength=0.6)
        seen = [live.mesh().vertices.copy()]
        for point, direction in zip(points[1:], directions[1:]):
            live.extend([point], [direction])
            seen.append(live.mesh().vertices.copy())
        assert live.end() == report
        a, b = at_once.mesh(), live.mesh()
        assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces), brush
        assert np.array_equal(at_once.modified(), live.modified()) and np.array_equal(at_once.labels(), live.labels())
        # The mesh changed as the pointer moved, not only at the end.
        assert not np.array_equal(seen[0], sphere.vertices) or brush == "grab"
        assert sum(not np.array_equal(x, y) for x, y in zip(seen, seen[1:])) >= len(points) // 2, brush


def test_a_stroke_under_way_must_end_before_another_begins(sphere):
    sculptor = sculpt.Sculptor(sphere)
    with pytest.raises(RuntimeError, match="no stroke is under way"):
        sculptor.extend([[0, 0, RADIUS]])
    sculptor.begin("draw", [0, 0, RADIUS], [0, 0, -1], radius=2.0)
    with pytest.raises(RuntimeError, match="end"):
        sculptor.begin("draw", [0, 0, RADIUS], [0, 0, -1], radius=2.0)
    sculptor.extend([[0.5, 0, RADIUS]], [[0, 0, -1]])
    assert sculptor.end()["dabs"] >= 2
    with pytest.raises(RuntimeError, match="no stroke is under way"):
        sculptor.end()


def test_a_ray_picks_the_clay_as_it_is_now(sphere):
    sculptor = sculpt.Sculptor(sphere)
    hit = sculptor.first_hit([0, 0, 3 * RADIUS], [0, 0, -1])
    assert hit[2] == pytest.approx(RADIUS, abs=0.05)  # the near side, not the far one
    assert sculptor.first_hit([0, 0, 3 * RADIUS], [0, 0, 1]) is None  # it looks away
    assert sculptor.first_hit([0, 0, 0], [0, 0, 1])[2] == pytest.approx(RADIUS, abs=0.05)  # from inside
    sculptor.stroke("draw", [[0, 0, RADIUS]], [[0, 0, -1]], radius=3.0, strength=1.0)
    raised = sculptor.first_hit([0, 0, 3 * RADIUS], [0, 0, -1])
    assert raised[2] == pytest.approx(sculptor.mesh().vertices[:, 2].max(), abs=0.05) and raised[2] > hit[2] + 0.1


def test_bad_input_is_refused_with_a_message(sphere):
    points, directions = stroke_over([0, 0, 1], [0.1, 0, 1])
    with pytest.raises(ValueError, match="unknown brush"):
        sculpt.stroke(sphere, "carve", points, directions, radius=2.0)
    with pytest.raises(ValueError, match="radius must be positive"):
        sculpt.stroke(sphere, "draw", points, directions, radius=0.0)
    with pytest.raises(ValueError, match="one view direction per stroke point"):
        sculpt.stroke(sphere, "draw", points, directions[:2], radius=2.0)
    with pytest.raises(ValueError, match="finite"):
        sculpt.stroke(sphere, "draw", [[np.nan, 0, 0]], None, radius=2.0)
    # Faces on vertices that do not exist.
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    with pytest.raises(idealize.MeshError):
        sculpt.Sculptor(idealize.Mesh(V, np.array([[0, 1, 7]])))


@pytest.mark.skipif(shapes.freecad() is None, reason="FreeCAD is not installed")
def test_a_layer_keeps_its_labels_where_the_stroke_did_not_reach():
    FreeCAD, Part, _ = shapes.freecad()
    layer, _ = shapes.quality_layer(Part.makeBox(60, 40, 20))
    top = [f["id"] for f in layer.features if f["params"]["normal"][2] > 0.99][0]
    sculptor = sculpt.Sculptor(layer)
    sculptor.stroke("draw", [[20, 20, 20], [40, 20, 20]], [[0, 0, -1]] * 2, radius=4.0, strength=0.5)
    mesh, labels, modified = sculptor.mesh(), sculptor.labels(), sculptor.modified()
    assert labels[modified].tolist() == [top] * int(modified.sum())  # new faces take the top's label
    # The faces the stroke did not change are the layer's, labels and all.
    before = {tuple(sorted(map(tuple, layer.idealized_vertices[f]))): l
              for f, l in zip(layer.mesh.faces, layer.labels)}
    for face, label in zip(mesh.faces[~modified], labels[~modified]):
        assert before[tuple(sorted(map(tuple, mesh.vertices[face])))] == label


@pytest.fixture(scope="module")
def box_layer():
    if shapes.freecad() is None:
        pytest.skip("FreeCAD is not installed")
    FreeCAD, Part, _ = shapes.freecad()
    return shapes.quality_layer(Part.makeBox(60, 40, 20))[0]


@pytest.fixture(scope="module")
def bumped(box_layer):
    """The box's top with a bump drawn on it, re-idealized."""
    sculptor = sculpt.Sculptor(box_layer)
    for _ in range(3):
        sculptor.stroke("draw", [[25, 20, 20], [35, 20, 20]], [[0, 0, -1]] * 2, radius=6.0, strength=1.0)
    return sculptor, idealize.reidealize(box_layer, sculptor.mesh(), sculptor.modified())


def test_reidealizing_an_unchanged_mesh_changes_nothing(box_layer):
    same = idealize.reidealize(box_layer, box_layer.idealized_mesh())
    assert not same.changed_faces.any()
    assert np.array_equal(same.labels, box_layer.labels)
    assert [f["params"] for f in same.features] == [f["params"] for f in box_layer.features]


def test_a_bump_becomes_new_features_and_the_rest_keeps_ids_and_parameters(box_layer, bumped):
    sculptor, layer = bumped
    count = len(box_layer.features)
    assert len(layer.features) > count
    for old, new in zip(box_layer.features, layer.features):
        assert new["id"] == old["id"] and new["type"] == old["type"] and new["params"] == old["params"]
    # Unmodified faces keep their features; the bump's faces are new features or the top's.
    modified = sculptor.modified()
    assert np.array_equal(np.asarray(layer.labels)[~modified], sculptor.labels()[~modified])
    top = [f["id"] for f in box_layer.features if f["params"]["normal"][2] > 0.99][0]
    assert set(np.asarray(layer.labels)[modified].tolist()) <= {top} | set(range(count, len(layer.features)))
    made = idealize.make_solid(layer)
    assert made.solid and not made.problems


def test_a_bump_taken_back_into_its_plane_is_that_plane_again(box_layer, bumped):
    """Without flags: the faces that are not the layer's triangles are the modified ones."""
    sculptor, layer = bumped
    mesh = sculptor.mesh()
    V = mesh.vertices.copy()
    V[:, 2] = np.minimum(V[:, 2], 20.0)  # the bump pressed flat into the top
    flat = idealize.reidealize(layer, idealize.Mesh(V, mesh.faces))
    top = [f["id"] for f in box_layer.features if f["params"]["normal"][2] > 0.99][0]
    labels = np.asarray(flat.labels)
    assert set(labels[flat.changed_faces].tolist()) == {top}
    assert all(f["triangles"] == 0 for f in flat.features[len(box_layer.features):])
    assert flat.features[top]["params"] == box_layer.features[top]["params"]
    made = idealize.make_solid(flat)
    assert made.solid and made.faces == 6 and made.volume == pytest.approx(60 * 40 * 20, rel=1e-6)


def test_a_mesh_sculpted_elsewhere_and_read_back_keeps_the_unchanged_features(box_layer, bumped, tmp_path):
    """The round trip through another program: written as STL (float32), read back, no flags."""
    sculptor, _ = bumped
    mesh = sculptor.mesh()
    path = tmp_path / "sculpted.stl"
    tri = mesh.vertices[mesh.faces].astype(np.float32)
    normals = np.zeros((len(tri), 3), np.float32)
    with open(path, "wb") as out:
        out.write(b"\0" * 80 + np.uint32(len(tri)).tobytes())
        record = np.zeros(len(tri), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
        record["n"], record["v"] = normals, tri
        out.write(record.tobytes())
    back = idealize.reidealize(box_layer, idealize.load_mesh(str(path)))
    kept = ~back.changed_faces
    # What the sculptor did not modify is recognised as the layer's own, labels and all.
    assert kept.sum() >= (~sculptor.modified()).sum() * 0.99
    for old, new in zip(box_layer.features, back.features):
        assert new["params"] == old["params"]
    assert idealize.make_solid(back).solid


def test_a_sculpt_edit_replays_the_same_layer(box_layer):
    from idealize import edit
    step = {"op": "sculpt", "strokes": [{"brush": "draw", "points": [[25, 20, 20], [35, 20, 20]],
                                         "directions": [[0, 0, -1]] * 2, "radius": 6.0, "strength": 1.0}]}
    first, again = edit.apply(box_layer, [step]), edit.apply(box_layer, [step])
    assert np.array_equal(first.idealized_vertices, again.idealized_vertices)
    assert np.array_equal(first.labels, again.labels) and first.features == again.features
    assert len(first.features) > len(box_layer.features)
    with pytest.raises(ValueError, match="needs brush and points"):
        edit.apply(box_layer, [{"op": "sculpt", "strokes": [{"brush": "draw", "size": 2}]}])


def test_an_edge_smoothed_round_becomes_a_cylinder_tangent_to_both_faces(box_layer):
    """The thesis's semi-defined feature: the two kept planes fix the new cylinder's axis and centre
    for a radius; the radius is the one most of the round's vertices lie on."""
    sculptor = sculpt.Sculptor(box_layer)
    d = np.array([0, 1, -1.0]) / np.sqrt(2)
    for _ in range(10):
        sculptor.stroke("smooth", [[6, 0, 20], [54, 0, 20]], [d, d], radius=4.0, strength=1.0)
    mesh, modified = sculptor.mesh(), sculptor.modified()
    layer = idealize.reidealize(box_layer, mesh, modified)
    count = len(box_layer.features)
    assert [f["params"] for f in layer.features[:count]] == [f["params"] for f in box_layer.features]
    # The feature at the middle of the rounded edge.
    middle = int(np.argmin(np.linalg.norm(mesh.vertices - [30.0, 0.0, 20.0], axis=1)))
    face = int(np.flatnonzero((mesh.faces == middle).any(axis=1))[0])
    round_ = layer.features[layer.labels[face]]
    assert round_["id"] >= count and round_["type"] == "cylinder"
    p = round_["params"]
    assert abs(p["axis"][0]) == pytest.approx(1.0, abs=1e-9)
    # Tangent to the top (z = 20) and the front (y = 0): the centre at the radius from both.
    assert p["point"][1] == pytest.approx(p["radius"], abs=1e-6)
    assert 20.0 - p["point"][2] == pytest.approx(p["radius"], abs=1e-6)
    # The radius is the one most vertices of the round vote for: within the round's own extent.
    on = np.unique(mesh.faces[np.asarray(layer.labels) == round_["id"]])
    assert 0.5 * np.ptp(mesh.vertices[on][:, 1]) < p["radius"] < 4.0 * np.ptp(mesh.vertices[on][:, 1])
    tangent = [r["features"] for r in layer.relations if r["kind"] == "tangent" and round_["id"] in r["features"]]
    assert len(tangent) == 2 and all(max(pair) == round_["id"] for pair in tangent)
    made = idealize.make_solid(layer)
    assert made.solid


def test_a_round_sculpted_towards_a_fillet_becomes_that_fillet(box_layer):
    """Sculpted as a user would with the target shown (bench/sculpt_targets.py): the re-idealized
    cylinder is the target fillet, radius and axis within 2 %."""
    targets = shapes.bench_module("sculpt_targets")
    radius = 4.0
    sculptor = sculpt.Sculptor(box_layer)
    target = targets.round_edge((60.0, 40.0, 20.0), radius)
    _, largest, _ = targets.sculpt_towards(sculptor, target, [radius, 0.6 * radius, 0.35 * radius], 0.01 * radius, 300)
    assert largest <= 0.05 * radius
    mesh = sculptor.mesh()
    layer = idealize.reidealize(box_layer, mesh, sculptor.modified())
    middle = int(np.argmin(np.linalg.norm(mesh.vertices - [30.0, radius * (1 - 0.5 ** 0.5), 20 - radius * (1 - 0.5 ** 0.5)], axis=1)))
    face = int(np.flatnonzero((mesh.faces == middle).any(axis=1))[0])
    p = layer.features[layer.labels[face]]["params"]
    assert layer.features[layer.labels[face]]["type"] == "cylinder"
    assert p["radius"] == pytest.approx(radius, rel=0.02)
    assert [p["point"][1], p["point"][2]] == pytest.approx([radius, 20.0 - radius], abs=0.02 * radius)


def test_a_bump_flattened_away_is_absorbed_by_its_face(box_layer):
    """Flattened faces within the tolerance of the top join it before anything is re-segmented."""
    sculptor = sculpt.Sculptor(box_layer)
    down = [[0, 0, -1.0]] * 2
    for _ in range(2):
        sculptor.stroke("draw", [[30, 20, 20]], down[:1], radius=5.0, strength=1.0)
    for _ in range(12):
        sculptor.stroke("flatten", [[20, 20, 20], [40, 20, 20]], down, radius=10.0, strength=1.0)
    layer = idealize.reidealize(box_layer, sculptor.mesh(), sculptor.modified())
    top = [f["id"] for f in box_layer.features if f["params"]["normal"][2] > 0.99][0]
    assert all(f["triangles"] == 0 for f in layer.features[len(box_layer.features):])
    assert set(np.asarray(layer.labels)[sculptor.modified()].tolist()) == {top}
    assert idealize.make_solid(layer).solid


def test_a_groove_sculpted_towards_a_cylinder_becomes_it_with_the_faces_direction():
    """The groove's cylinder: its axis exactly the block's x (snapped to the kept faces' directions,
    and in their group of parallel features), its radius and axis within 2 % of the target's (refitted to its inner vertices, away from the
    rim the brushes rounded). On a mesh of 1 mm: four edges across the groove's radius."""
    if shapes.freecad() is None:
        pytest.skip("FreeCAD is not installed")
    FreeCAD, Part, _ = shapes.freecad()
    box_layer = shapes.quality_layer(Part.makeBox(60, 40, 20), 1.0)[0]
    targets = shapes.bench_module("sculpt_targets")
    radius, depth, y = 4.0, 2.5, 20.0
    sculptor = sculpt.Sculptor(box_layer)
    target = targets.groove((60.0, 40.0, 20.0), y, 20.0 + radius - depth, radius)
    width = (radius ** 2 - (radius - depth) ** 2) ** 0.5
    targets.sculpt_towards(sculptor, target, [width, 0.6 * width, 0.35 * width], 0.01 * radius, 300)
    mesh = sculptor.mesh()
    layer = idealize.reidealize(box_layer, mesh, sculptor.modified())
    bottom = int(np.argmin(np.linalg.norm(mesh.vertices - [30.0, y, 20.0 - depth], axis=1)))
    face = int(np.flatnonzero((mesh.faces == bottom).any(axis=1))[0])
    groove = layer.features[layer.labels[face]]
    assert groove["id"] >= len(box_layer.features) and groove["type"] == "cylinder"
    p = groove["params"]
    assert any(np.array_equal(np.abs(p["axis"]), np.abs(f["params"]["normal"])) for f in box_layer.features)
    assert abs(p["axis"][0]) == pytest.approx(1.0)
    # ... and related to them as the idealization relates parallel features: one group.
    ends = {f["id"] for f in box_layer.features if f["type"] == "plane" and abs(f["params"]["normal"][0]) == 1.0}
    assert any(r["kind"] == "parallel" and {groove["id"]} | ends <= set(r["features"]) for r in layer.relations)
    parallel = [f for r in layer.relations if r["kind"] == "parallel" for f in r["features"]]
    assert len(parallel) == len(set(parallel))  # each feature in one group: the kept ones' grew
    assert len({(r["kind"], tuple(r["features"])) for r in layer.relations}) == len(layer.relations)
    assert p["radius"] == pytest.approx(radius, rel=0.02)
    assert [p["point"][1], p["point"][2]] == pytest.approx([y, 20.0 + radius - depth], abs=0.02 * radius)
    assert idealize.make_solid(layer).solid


def test_a_region_can_be_identified_as_measured(box_layer):
    """`measured` overrides the mesh kind that most of a mesh's patches suggest (the ring of CAD
    faces around a sculpted region)."""
    mesh = box_layer.mesh
    assert box_layer.mesh_kind == "exact tessellation"
    assert idealize.idealize(mesh, measured=True).mesh_kind != "exact tessellation"


def _two_cubes_sharing_an_edge():
    """Two unit cubes touching along one edge (that edge has four faces), as a real export has it."""
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    second = corners + [1.0, 1.0, 0.0]  # shares the edge x = y = 1 with the first
    V = np.concatenate([corners, second])
    F = np.concatenate([faces, faces + 8])
    # Weld the shared edge's two vertices.
    V, index = np.unique(V, axis=0, return_inverse=True)
    return V, index[F]


def test_a_mesh_that_is_not_manifold_is_cut_apart_to_be_sculpted():
    V, F = _two_cubes_sharing_an_edge()
    with pytest.raises(idealize.MeshError):
        from idealize import _native
        _native.Sculptor(np.ascontiguousarray(V), np.ascontiguousarray(F, dtype=np.int32), [])
    V2, F2 = sculpt.split_where_not_manifold(V, F)
    # Every face kept, at the same place; the shared edge's two vertices copied once each.
    assert len(F2) == len(F) and np.array_equal(V2[F2], V[F])
    assert len(V2) == len(V) + 2
    directed = np.concatenate([F2[:, [0, 1]], F2[:, [1, 2]], F2[:, [2, 0]]])
    _, counts = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    assert counts.max() == 2 and len(np.unique(directed, axis=0)) == len(directed)
    sculptor = sculpt.Sculptor(idealize.Mesh(V, F))
    assert sculptor.repaired
    sculptor.stroke("draw", [[0.5, 0.5, 1.0]], [[0, 0, -1.0]], radius=1.2, strength=0.5)
    assert sculptor.modified().any()
    # Three faces on one edge: each its own sheet along it.
    V3 = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]], float)
    F3 = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    V4, F4 = sculpt.split_where_not_manifold(V3, F3)
    assert np.array_equal(V4[F4], V3[F3]) and len(np.unique(F4)) == 5 + 4  # the edge's ends, twice more each
    # A manifold mesh is left as it is.
    assert not sculpt.Sculptor(idealize.Mesh(V, F[:12])).repaired
