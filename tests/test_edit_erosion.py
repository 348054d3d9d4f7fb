"""Deleting a group that sits across the edges of several faces (issue 52; thesis 6.2.2, the
erosion's three cases): the faces around the gap meet along new edges (an old edge runs on through
the gap), at new corners (new edges meet new edges), and identical faces a group kept apart join
(the false edge is never made). Every result against the part built in FreeCAD without the group."""
import copy

import numpy as np
import pytest

import idealize
import shapes
from idealize import edit
from test_edit_groups import check_deleted, of_type, plane_at_height

pytestmark = pytest.mark.skipif(shapes.freecad() is None, reason="FreeCAD is not installed")


def build(make):
    FreeCAD, Part, _ = shapes.freecad()
    solid, without = make(FreeCAD.Vector, Part)
    layer, _ = shapes.quality_layer(solid)
    return layer, without


def plane_normal_to(layer, axis, at):
    """The planes whose normal is along coordinate `axis`, through coordinate `at` on it."""
    return [f["id"] for f in layer.features if f["type"] == "plane"
            and abs(abs(f["params"]["normal"][axis]) - 1) < 1e-9 and abs(f["params"]["point"][axis] - at) < 1e-6]


def not_on(layer, shape):
    """The features whose vertices leave the faces of `shape`: what was added to or cut from it."""
    FreeCAD, Part, _ = shapes.freecad()
    shell = shape.Shells[0]
    labels = np.asarray(layer.labels)
    out = []
    for f in layer.features:
        points = layer.idealized_vertices[np.unique(layer.mesh.faces[labels == f["id"]])]
        if any(shell.distToShape(Part.Vertex(FreeCAD.Vector(*p)))[0] > 1e-6 for p in points):
            out.append(f["id"])
    return out


@pytest.fixture(scope="module")
def edge_notch():
    """A 60 x 40 x 20 block with a 10 x 8 x 6 notch in its top front edge."""
    return build(lambda V, Part: (Part.makeBox(60, 40, 20).cut(Part.makeBox(10, 8, 6, V(25, 0, 14))),
                                  Part.makeBox(60, 40, 20)))


@pytest.fixture(scope="module")
def corner_notch():
    """The same block with the notch at its corner."""
    return build(lambda V, Part: (Part.makeBox(60, 40, 20).cut(Part.makeBox(10, 8, 6, V(50, 0, 14))),
                                  Part.makeBox(60, 40, 20)))


@pytest.fixture(scope="module")
def step():
    """The block with a step cut along one end, 20 long and 8 deep."""
    return build(lambda V, Part: (Part.makeBox(60, 40, 20).cut(Part.makeBox(20, 40, 8, V(40, 0, 12))),
                                  Part.makeBox(60, 40, 20)))


@pytest.fixture(scope="module")
def riser_boss():
    """A one-step block (the step's riser at x = 40) with a block boss standing against the riser."""
    def make(V, Part):
        base = Part.makeBox(60, 40, 10).fuse(Part.makeBox(20, 40, 10, V(40, 0, 10))).removeSplitter()
        return base.fuse(Part.makeBox(8, 10, 6, V(32, 15, 10))).removeSplitter(), base
    return build(make)


@pytest.fixture(scope="module")
def overhang():
    """A plate with a round boss over its front edge, its underside 4 above the plate's bottom."""
    return build(lambda V, Part: (Part.makeBox(60, 40, 10).fuse(Part.makeCylinder(6, 11, V(30, 0, 4))).removeSplitter(),
                                  Part.makeBox(60, 40, 10)))


@pytest.fixture(scope="module")
def channel_rib():
    """A channel between two walls with a rib across it from wall to wall: the rib parts the
    channel's floor into two faces on one plane."""
    def make(V, Part):
        channel = Part.makeBox(60, 40, 20).cut(Part.makeBox(40, 40, 12, V(10, 0, 8)))
        return channel.fuse(Part.makeBox(40, 6, 5, V(10, 17, 8))).removeSplitter(), channel
    return build(make)


@pytest.fixture(scope="module")
def shaft_notch():
    """A shaft (r 15) with a notch in the edge of its end face."""
    return build(lambda V, Part: (Part.makeCylinder(15, 60).cut(Part.makeBox(6, 8, 6, V(-3, 10, 54))),
                                  Part.makeCylinder(15, 60)))


def test_a_notch_in_an_edge_is_a_group_whose_edge_runs_on_when_it_is_deleted(edge_notch):
    layer, block = edge_notch
    notch = not_on(layer, block)
    top, = plane_at_height(layer, 20.0)
    front, = plane_normal_to(layer, 1, 0.0)
    for member in notch:
        assert edit.feature_group(layer, member) == {"members": notch, "hosts": sorted([top, front])}
    after = edit.delete(layer, notch)
    check_deleted(layer, after, None, 6, block.Volume)
    assert (after.new_edges, after.corners, after.merged) == (1, 0, [])
    new_top, new_front = after.renumbered[top], after.renumbered[front]
    assert sorted(after.changed) == sorted([new_top, new_front])
    assert {new_top, new_front} in [{a["a"], a["b"]} for a in after.adjacency]


def test_a_notch_at_a_corner_closes_with_three_new_edges_meeting(corner_notch):
    layer, block = corner_notch
    notch = not_on(layer, block)
    assert edit.feature_group(layer, notch[0])["members"] == notch
    after = edit.delete(layer, notch)
    check_deleted(layer, after, None, 6, block.Volume)
    assert (after.new_edges, after.corners) == (3, 1)


def test_a_step_across_an_end_deletes_back_to_the_block(step):
    """Four faces around the gap and no old edge running through it: two new corners joined by a
    new edge, the shortest of the two ways the new edges could meet (the other needs the two
    parallel sides to meet)."""
    layer, block = step
    riser, = plane_normal_to(layer, 0, 40.0)
    tread, = plane_at_height(layer, 12.0)
    assert edit.feature_group(layer, riser)["members"] == [riser]  # a face of the outline: no group
    after = edit.delete(layer, [riser, tread])
    check_deleted(layer, after, None, 6, block.Volume)
    assert (after.new_edges, after.corners) == (5, 2)


def test_a_boss_against_a_wall_deletes_to_the_step(riser_boss):
    layer, base = riser_boss
    boss = not_on(layer, base)
    riser, = plane_normal_to(layer, 0, 40.0)
    lower, = plane_at_height(layer, 10.0)
    assert edit.feature_group(layer, boss[0]) == {"members": boss, "hosts": sorted([riser, lower])}
    after = edit.delete(layer, boss)
    check_deleted(layer, after, None, 8, base.Volume)
    assert (after.new_edges, after.corners) == (1, 0)


def test_a_boss_over_an_edge_with_its_own_underside_deletes_to_the_plate(overhang):
    layer, plate = overhang
    boss = not_on(layer, plate)
    assert len(boss) == 3  # wall, top, underside
    assert edit.feature_group(layer, of_type(layer, "cylinder", radius=6.0)[0])["members"] == boss
    after = edit.delete(layer, boss)
    check_deleted(layer, after, None, 6, plate.Volume)


def test_a_boss_whose_base_is_part_of_the_bottom_face_is_refused_and_changes_nothing():
    """The boss's base lies in the plate's bottom face: deleting it would take triangles from that
    face, which erosion never does."""
    layer, plate = build(lambda V, Part: (
        Part.makeBox(60, 40, 10).fuse(Part.makeCylinder(6, 15, V(30, 0, 0))).removeSplitter(), Part.makeBox(60, 40, 10)))
    boss = of_type(layer, "cylinder", radius=6.0) + plane_at_height(layer, 15.0)
    bottom, = plane_at_height(layer, 0.0)
    assert len(boss) == 2
    labels, vertices = copy.deepcopy(layer.labels), layer.idealized_vertices.copy()
    with pytest.raises(edit.EditConflict, match=f"feature {bottom} cannot close over the gap"):
        edit.delete(layer, boss)
    assert np.array_equal(labels, layer.labels) and np.array_equal(vertices, layer.idealized_vertices)


def test_a_rib_between_walls_deletes_and_the_floor_faces_join(channel_rib):
    """The false edge: the rib kept two faces of one plane apart; deleting it joins them into one
    feature instead of making an edge between them."""
    layer, channel = channel_rib
    rib = not_on(layer, channel)
    floors = plane_at_height(layer, 8.0)
    assert len(rib) == 3 and len(floors) == 2
    after = edit.delete(layer, rib)
    check_deleted(layer, after, None, 10, channel.Volume)
    assert after.merged == [(max(floors), min(floors))]
    assert after.renumbered[floors[0]] == after.renumbered[floors[1]]
    assert len(after.features) == len(layer.features) - 4
    floor = after.renumbered[min(floors)]
    assert np.sum(np.asarray(after.labels) == floor) > np.sum(np.asarray(layer.labels) == min(floors))
    # The joined floor borders what both halves bordered, and no feature borders itself.
    around = {a["b"] if a["a"] == floor else a["a"] for a in after.adjacency if floor in (a["a"], a["b"])}
    assert floor not in around and len(around) == 4  # the two walls and the two ends


def test_a_notch_in_the_edge_of_a_shaft_closes_along_a_circle(shaft_notch):
    layer, shaft = shaft_notch
    notch = not_on(layer, shaft)
    outside, = of_type(layer, "cylinder", radius=15.0)
    end, = plane_at_height(layer, 60.0)
    assert edit.feature_group(layer, notch[0]) == {"members": notch, "hosts": sorted([outside, end])}
    after = edit.delete(layer, notch)
    check_deleted(layer, after, None, 3, shaft.Volume)
    assert after.new_edges == 1
    # The new edge's vertices lie on the end face's circle.
    labels = np.asarray(after.labels)
    rim = np.intersect1d(np.unique(after.mesh.faces[labels == after.renumbered[outside]]),
                         np.unique(after.mesh.faces[labels == after.renumbered[end]]))
    points = after.idealized_vertices[rim]
    assert np.allclose(np.hypot(points[:, 0], points[:, 1]), 15.0, atol=1e-6)
    assert np.allclose(points[:, 2], 60.0, atol=1e-6)


def test_a_group_across_edges_moves_along_them_but_does_not_travel_as_a_decal(edge_notch):
    layer, block = edge_notch
    notch = not_on(layer, block)
    moved = edit.move(layer, notch, (5.0, 0.0, 0.0))
    made = idealize.make_solid(moved)
    assert made.solid and made.faces == 10
    assert made.volume == pytest.approx(block.Volume - 10 * 8 * 6, rel=1e-6)
    with pytest.raises(edit.EditConflict, match="travels as a decal"):
        edit.copy(layer, notch, (15.0, 0.0, 0.0))
