"""Structure-altering editing (issue 52): feature groups from the mesh's border loops; deleting a
group with its gaps closed on the faces around it; copying and moving it on its host planes or
cylinders, or onto another plane; a hole made through and blind again. Every result against the
part built edited in FreeCAD."""
import copy
import math

import numpy as np
import pytest

import idealize
import shapes
from idealize import edit

pytestmark = pytest.mark.skipif(shapes.freecad() is None, reason="FreeCAD is not installed")


_layer = shapes.quality_layer


@pytest.fixture(scope="module")
def boss():
    """A 60 x 40 x 10 plate with a round boss (r 8, 15 high) filleted (r 3) at its base."""
    FreeCAD, Part, _ = shapes.freecad()
    solid = Part.makeBox(60, 40, 10).fuse(Part.makeCylinder(8, 15, FreeCAD.Vector(30, 20, 10))).removeSplitter()
    base = [e for e in solid.Edges if e.Curve.__class__.__name__ == "Circle" and abs(e.Vertexes[0].Point.z - 10) < 1e-6]
    return _layer(solid.makeFillet(3, base))


@pytest.fixture(scope="module")
def counterbore():
    """A 60 x 40 x 10 plate with a counterbored through hole (r 4, counterbore r 7 and 4 deep)."""
    FreeCAD, Part, _ = shapes.freecad()
    solid = Part.makeBox(60, 40, 10).cut(Part.makeCylinder(4, 10, FreeCAD.Vector(30, 20, 0)))
    return _layer(solid.cut(Part.makeCylinder(7, 4, FreeCAD.Vector(30, 20, 6))))


@pytest.fixture(scope="module")
def shaft():
    """A shaft (r 15, 60 long) with a radial through hole (r 4): its gaps are on a cylinder."""
    FreeCAD, Part, _ = shapes.freecad()
    solid = Part.makeCylinder(15, 60)
    return _layer(solid.cut(Part.makeCylinder(4, 40, FreeCAD.Vector(0, -20, 30), FreeCAD.Vector(0, 1, 0))))


def of_type(layer, kind, **params):
    return [f["id"] for f in layer.features if f["type"] == kind
            and all(abs(f["params"][k] - v) < 1e-3 for k, v in params.items())]


def plane_at_height(layer, z):
    return [f["id"] for f in layer.features if f["type"] == "plane" and abs(abs(f["params"]["normal"][2]) - 1) < 1e-9
            and abs(f["params"]["point"][2] - z) < 1e-6]


def well_shaped(layer):
    """The share of the triangles the edit made whose smallest angle is at least 20 degrees."""
    assert layer.created.any()
    return np.mean(shapes.min_angles(layer.idealized_vertices, layer.mesh.faces)[layer.created] >= 20.0)


def check_deleted(before, after, solid, faces, volume):
    """The solid valid with `faces` faces and the volume within 0.5 % (here: to rounding); the mesh
    closed, manifold and not self-intersecting; the features that remain keep their surfaces
    exactly; the triangles closing the gaps well shaped."""
    made = idealize.make_solid(after)
    assert made.solid and not made.problems
    assert made.faces == faces
    assert made.volume == pytest.approx(volume, rel=1e-6)
    check = idealize.segment(after.mesh, self_intersections=True).mesh_check
    assert check["boundary_edges"] == 0 and check["nonmanifold_edges"] == 0 and check["shells"] == 1
    assert check["self_intersecting_pairs"] == 0
    joined = dict(getattr(after, "merged", []))  # a face joined to an identical one takes that one's parameters
    for old, new in after.renumbered.items():
        assert after.features[new]["params"] == before.features[joined.get(old, old)]["params"]
        assert after.features[new]["type"] == before.features[old]["type"]
    assert well_shaped(after) >= 0.99
    assert after.deviation["max"] <= 1e-6 * np.linalg.norm(np.ptp(after.mesh.vertices, axis=0))


def test_the_group_of_a_boss_is_its_wall_top_and_fillet_on_the_plate(boss):
    layer, _ = boss
    wall, = of_type(layer, "cylinder", radius=8.0)
    top, = plane_at_height(layer, 25.0)
    fillet, = of_type(layer, "torus")
    plate, = plane_at_height(layer, 10.0)
    for member in (wall, top, fillet):
        assert edit.feature_group(layer, member) == {"members": sorted([wall, top, fillet]), "hosts": [plate]}
    # A face of the part's outline has no group of its own.
    assert edit.feature_group(layer, plate)["members"] == [plate]


def test_deleting_a_boss_leaves_the_plate(boss):
    layer, _ = boss
    before = copy.deepcopy(layer.labels), layer.idealized_vertices.copy(), copy.deepcopy(layer.features)
    group = edit.feature_group(layer, of_type(layer, "cylinder", radius=8.0)[0])
    after = edit.delete(layer, group["members"])
    _, Part, _ = shapes.freecad()
    check_deleted(layer, after, None, 6, Part.makeBox(60, 40, 10).Volume)
    assert len(after.features) == len(layer.features) - 3
    assert after.changed == [after.renumbered[group["hosts"][0]]]
    # The input layer is not modified.
    assert np.array_equal(before[0], layer.labels) and np.array_equal(before[1], layer.idealized_vertices)
    assert before[2] == layer.features


def test_a_counterbored_hole_is_one_group_and_deletes_to_a_plain_plate(counterbore):
    layer, _ = counterbore
    hole, = of_type(layer, "cylinder", radius=4.0)
    bore, = of_type(layer, "cylinder", radius=7.0)
    step, = plane_at_height(layer, 6.0)
    group = edit.feature_group(layer, hole)
    assert {hole, bore, step} <= set(group["members"])
    assert sorted(group["hosts"]) == sorted(plane_at_height(layer, 10.0) + plane_at_height(layer, 0.0))
    assert edit.feature_group(layer, bore) == group
    after = edit.delete(layer, group["members"])
    _, Part, _ = shapes.freecad()
    check_deleted(layer, after, None, 6, Part.makeBox(60, 40, 10).Volume)


def test_a_radial_hole_closes_on_the_shaft_cylinder(shaft):
    layer, _ = shaft
    hole, = of_type(layer, "cylinder", radius=4.0)
    outside, = of_type(layer, "cylinder", radius=15.0)
    group = edit.feature_group(layer, hole)
    assert group == {"members": [hole], "hosts": [outside]}
    after = edit.delete(layer, group["members"])
    _, Part, _ = shapes.freecad()
    check_deleted(layer, after, None, 3, Part.makeCylinder(15, 60).Volume)


def test_deleting_names_no_feature_or_all_is_an_error(boss):
    layer, _ = boss
    with pytest.raises(ValueError, match="no feature"):
        edit.delete(layer, [len(layer.features)])
    with pytest.raises(ValueError, match="every feature"):
        edit.delete(layer, list(range(len(layer.features))))


def bossed_plate(centres, width=100.0):
    """A width x 60 x 10 plate with round bosses (r 8, 15 high, filleted r 3 at the base) at `centres`."""
    FreeCAD, Part, _ = shapes.freecad()
    solid = Part.makeBox(width, 60, 10)
    for x, y in centres:
        solid = solid.fuse(Part.makeCylinder(8, 15, FreeCAD.Vector(x, y, 10)))
    solid = solid.removeSplitter()
    base = [e for e in solid.Edges if e.Curve.__class__.__name__ == "Circle" and abs(e.Vertexes[0].Point.z - 10) < 1e-6]
    return solid.makeFillet(3, base)


@pytest.fixture(scope="module")
def wide_boss():
    return _layer(bossed_plate([(30, 30)]))


@pytest.fixture(scope="module")
def pocketed():
    """A 100 x 60 x 20 block with a 20 x 12 pocket 8 deep, its corners rounded (r 2), and a recess
    30 x 30 x 15 in its bottom under the right half of the top."""
    FreeCAD, Part, _ = shapes.freecad()
    solid = Part.makeBox(100, 60, 20).cut(Part.makeBox(20, 12, 8, FreeCAD.Vector(15, 24, 12)))
    corners = [e for e in solid.Edges if e.Curve.__class__.__name__ == "Line" and min(v.Point.z for v in e.Vertexes) > 11
               and abs(e.Vertexes[0].Point.z - e.Vertexes[1].Point.z) > 1]
    solid = solid.makeFillet(2, corners)
    return _layer(solid.cut(Part.makeBox(30, 30, 15, FreeCAD.Vector(60, 15, 0))))


def test_a_copied_boss_is_the_boss_moved_and_the_rest_stays(wide_boss):
    layer, _ = wide_boss
    group = edit.feature_group(layer, of_type(layer, "cylinder", radius=8.0)[0])
    after = edit.copy(layer, group["members"], (40, 0, 0))
    made = idealize.make_solid(after)
    assert made.solid and not made.problems and made.faces == 12
    assert made.volume == pytest.approx(bossed_plate([(30, 30), (70, 30)]).Volume, rel=1e-6)
    for old in range(len(layer.features)):
        assert after.features[old]["params"] == layer.features[old]["params"]
    for old, new in zip(group["members"], after.copies):
        kind, before, copied = layer.features[old]["type"], layer.features[old]["params"], after.features[new]["params"]
        assert after.features[new]["type"] == kind
        anchor = "center" if kind == "torus" else "point"
        assert np.allclose(np.asarray(copied[anchor]) - before[anchor], [40, 0, 0], atol=1e-9)
        for key in ("radius", "minor"):
            if key in before:
                assert copied[key] == pytest.approx(before[key], abs=1e-12)
    check = idealize.segment(after.mesh, self_intersections=True).mesh_check
    assert check["boundary_edges"] == 0 and check["nonmanifold_edges"] == 0 and check["self_intersecting_pairs"] == 0
    assert well_shaped(after) >= 0.99


@pytest.mark.parametrize("translation", [(45, 10, 0), (3, -2, 0)])  # far, and over its own place
def test_a_moved_boss_keeps_its_ids_and_lands_where_asked(wide_boss, translation):
    layer, _ = wide_boss
    group = edit.feature_group(layer, of_type(layer, "cylinder", radius=8.0)[0])
    after = edit.move(layer, group["members"], translation)
    assert len(after.features) == len(layer.features)
    wall, = of_type(after, "cylinder", radius=8.0)
    assert wall in group["members"]
    centre = np.add([30, 30], translation[:2])
    assert np.allclose(np.asarray(after.features[wall]["params"]["point"])[:2], centre, atol=1e-9)
    for f in range(len(layer.features)):
        if f not in group["members"]:
            assert after.features[f]["params"] == layer.features[f]["params"]
    made = idealize.make_solid(after)
    assert made.solid and made.faces == 9
    assert made.volume == pytest.approx(bossed_plate([tuple(centre)]).Volume, rel=1e-6)
    assert well_shaped(after) >= 0.99


@pytest.mark.parametrize("translation, conflict", [
    ((62, 0, 0), "reaches feature"),       # over the plate's edge
    ((10, 0, 0), None),                    # overlaps its own place: copy refuses
    ((0, 0, 2), "off the plane"),          # off its host
])
def test_a_copy_that_cannot_take_its_place_is_refused_and_changes_nothing(wide_boss, translation, conflict):
    layer, _ = wide_boss
    group = edit.feature_group(layer, of_type(layer, "cylinder", radius=8.0)[0])
    labels = copy.deepcopy(layer.labels)
    with pytest.raises(edit.EditConflict, match=conflict or "own place"):
        edit.copy(layer, group["members"], translation)
    assert np.array_equal(labels, layer.labels)


def test_a_pocket_turns_and_a_copy_over_the_recess_would_break_through(pocketed):
    layer, solid = pocketed
    floor, = plane_at_height(layer, 12.0)
    group = edit.feature_group(layer, floor)
    assert len(group["members"]) == 9  # floor, four walls, four corner fillets
    turned = edit.move(layer, group["members"], (0, 0, 0), rotation=90)
    made = idealize.make_solid(turned)
    assert made.solid and made.faces == len(layer.features)
    assert made.volume == pytest.approx(solid.Volume, rel=1e-6)
    walls = [f for f in group["members"] if turned.features[f]["type"] == "plane" and f != floor]
    normals = {tuple(np.round(np.abs(layer.features[f]["params"]["normal"]), 9)) for f in walls}
    assert {tuple(np.round(np.abs(turned.features[f]["params"]["normal"]), 9)) for f in walls} == normals
    with pytest.raises(edit.EditConflict, match="cut through the part"):
        edit.copy(layer, group["members"], (50, 0, 0))


def blind_plate(depth):
    """A 100 x 60 x 10 plate with a hole of radius 4 at (30, 30), `depth` deep from the top (10: through)."""
    FreeCAD, Part, _ = shapes.freecad()
    return Part.makeBox(100, 60, 10).cut(Part.makeCylinder(4, depth, FreeCAD.Vector(30, 30, 10 - depth)))


@pytest.fixture(scope="module")
def blind():
    return _layer(blind_plate(6.0))


def test_a_blind_hole_goes_through_and_back(blind):
    layer, _ = blind
    wall, = of_type(layer, "cylinder", radius=4.0)
    top, = plane_at_height(layer, 10.0)
    bottom, = plane_at_height(layer, 0.0)
    through = edit.set_depth(layer, wall, 25.0)  # past the wall: through, 10 deep
    assert through.hole["through"] and through.hole["floor"] is None
    assert through.hole["depth"] == pytest.approx(10.0, abs=1e-9)
    assert sorted(through.changed) == sorted([through.renumbered[top], through.renumbered[bottom], through.hole["wall"]])
    check_deleted(layer, through, None, 7, blind_plate(10.0).Volume)
    again = edit.set_depth(through, through.hole["wall"], 4.0)  # blind again, 4 deep from the larger face
    assert not again.hole["through"] and again.hole["depth"] == pytest.approx(4.0)
    floor = again.features[again.hole["floor"]]
    assert floor["type"] == "plane" and abs(floor["params"]["point"][2] - 6.0) < 1e-6
    check_deleted(through, again, None, 8, blind_plate(4.0).Volume)
    # The wall keeps its radius and axis exactly.
    for key in ("radius", "axis"):
        assert np.allclose(again.features[again.hole["wall"]]["params"][key], layer.features[wall]["params"][key],
                           atol=1e-12)


def test_only_a_plain_hole_in_planes_gets_a_depth(counterbore, shaft, boss):
    layer, _ = counterbore
    with pytest.raises(edit.EditConflict, match="only a plain hole"):
        edit.set_depth(layer, of_type(layer, "cylinder", radius=4.0)[0], 3.0)
    layer, _ = shaft
    with pytest.raises(edit.EditConflict, match="in planes only"):
        edit.set_depth(layer, of_type(layer, "cylinder", radius=4.0)[0], 3.0)
    layer, _ = boss
    with pytest.raises(edit.EditConflict, match="boss, not a hole"):
        edit.set_depth(layer, of_type(layer, "cylinder", radius=8.0)[0], 3.0)
    with pytest.raises(ValueError, match="positive"):
        edit.set_depth(layer, of_type(layer, "cylinder", radius=8.0)[0], -1.0)


def test_a_boss_goes_onto_the_plate_bottom(wide_boss):
    layer, _ = wide_boss
    group = edit.feature_group(layer, of_type(layer, "cylinder", radius=8.0)[0])
    bottom, = plane_at_height(layer, 0.0)
    FreeCAD, Part, _ = shapes.freecad()
    solid = Part.makeBox(100, 60, 10).fuse(Part.makeCylinder(8, 15, FreeCAD.Vector(30, 30, 10)))
    solid = solid.fuse(Part.makeCylinder(8, 15, FreeCAD.Vector(70, 30, -15))).removeSplitter()
    base = [e for e in solid.Edges if e.Curve.__class__.__name__ == "Circle"
            and min(abs(e.Vertexes[0].Point.z - 10), abs(e.Vertexes[0].Point.z)) < 1e-6]
    expected = solid.makeFillet(3, base)
    after = edit.copy(layer, group["members"], (40, 0, 0), onto=bottom)
    made = idealize.make_solid(after)
    assert made.solid and made.faces == len(expected.Faces)
    assert made.volume == pytest.approx(expected.Volume, rel=1e-6)
    top = after.features[after.copies[group["members"].index(plane_at_height(layer, 25.0)[0])]]
    assert abs(top["params"]["point"][2] + 15.0) < 1e-6 and abs(abs(top["params"]["normal"][2]) - 1) < 1e-12
    assert well_shaped(after) >= 0.99
    moved = edit.move(layer, group["members"], (40, 0, 0), onto=bottom)
    plate = Part.makeBox(100, 60, 10).Volume
    assert idealize.make_solid(moved).volume == pytest.approx(plate + (expected.Volume - plate) / 2, rel=1e-6)
    with pytest.raises(edit.EditConflict, match="reaches feature"):  # a side face 10 high: the boss does not fit
        edit.copy(layer, group["members"], (0, 0, 0), onto=[f["id"] for f in layer.features if f["type"] == "plane"
                                                          and abs(f["params"]["normal"][1]) > 0.999][0])


def radial_holes(holes):
    """The shaft (r 15, 60 long) with radial through holes (r 4) at (height, angle in degrees)."""
    FreeCAD, Part, _ = shapes.freecad()
    solid = Part.makeCylinder(15, 60)
    for z, angle in holes:
        d = FreeCAD.Vector(math.cos(math.radians(angle)), math.sin(math.radians(angle)), 0)
        solid = solid.cut(Part.makeCylinder(4, 40, FreeCAD.Vector(0, 0, z) - d * 20, d))
    return solid


def test_a_radial_hole_is_copied_and_turned_round_the_shaft(shaft):
    layer, _ = shaft
    hole, = of_type(layer, "cylinder", radius=4.0)
    outside, = of_type(layer, "cylinder", radius=15.0)
    before = idealize.make_solid(layer).volume - radial_holes([(30, 90)]).Volume  # the B-rep's own error
    copied = edit.copy(layer, [hole], (0, 0, 15), rotation=90)
    made = idealize.make_solid(copied)
    assert made.solid and made.faces == 5 and copied.changed == sorted([outside, copied.copies[0]])
    assert made.volume - before == pytest.approx(radial_holes([(30, 90), (45, 180)]).Volume, rel=1e-4)
    axis = copied.features[copied.copies[0]]["params"]["axis"]
    assert abs(axis[0]) == pytest.approx(1.0, abs=1e-9)  # turned a quarter from the y axis
    assert well_shaped(copied) >= 0.99
    moved = edit.move(layer, [hole], (0, 0, -12), rotation=45)
    assert idealize.make_solid(moved).volume - before == pytest.approx(radial_holes([(18, 135)]).Volume, rel=1e-4)
    with pytest.raises(edit.EditConflict, match="cut through the part"):  # across the hole itself
        edit.copy(layer, [hole], (0, 0, 0), rotation=90)
    with pytest.raises(edit.EditConflict, match="off the cylinder"):
        edit.copy(layer, [hole], (1, 0, 0))
