"""Structure-altering editing, first part (issue 52): feature groups from the mesh's border loops,
and deleting a group with its gaps closed on the faces around it."""
import copy

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


@pytest.fixture(scope="module")
def step():
    """A 60 x 40 x 20 block with a step cut along one end: no island."""
    FreeCAD, Part, _ = shapes.freecad()
    return _layer(Part.makeBox(60, 40, 20).cut(Part.makeBox(20, 40, 8, FreeCAD.Vector(40, 0, 12))))


def of_type(layer, kind, **params):
    return [f["id"] for f in layer.features if f["type"] == kind
            and all(abs(f["params"][k] - v) < 1e-3 for k, v in params.items())]


def plane_at_height(layer, z):
    return [f["id"] for f in layer.features if f["type"] == "plane" and abs(abs(f["params"]["normal"][2]) - 1) < 1e-9
            and abs(f["params"]["point"][2] - z) < 1e-6]


def check_deleted(before, after, solid, faces, volume):
    """The solid valid with `faces` faces and the volume within 0.5 % (here: to rounding); the mesh
    closed, manifold and not self-intersecting; the features that remain keep their surfaces
    exactly; the closed gaps' triangles well shaped."""
    made = idealize.make_solid(after)
    assert made.solid and not made.problems
    assert made.faces == faces
    assert made.volume == pytest.approx(volume, rel=1e-6)
    check = idealize.segment(after.mesh, self_intersections=True).mesh_check
    assert check["boundary_edges"] == 0 and check["nonmanifold_edges"] == 0 and check["shells"] == 1
    assert check["self_intersecting_pairs"] == 0
    for old, new in after.renumbered.items():
        assert after.features[new]["params"] == before.features[old]["params"]
        assert after.features[new]["type"] == before.features[old]["type"]
    hosts = np.isin(after.labels, after.changed)
    angles = shapes.min_angles(after.idealized_vertices, after.mesh.faces)
    assert np.mean(angles[hosts] >= 20.0) >= 0.99
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


def test_a_step_across_an_edge_is_no_group_and_is_refused(step):
    layer, _ = step
    riser, = [f["id"] for f in layer.features if f["type"] == "plane" and abs(f["params"]["normal"][0]) > 0.999
              and abs(f["params"]["point"][0] - 40.0) < 1e-6]
    tread, = plane_at_height(layer, 12.0)
    assert edit.feature_group(layer, riser)["members"] == [riser]
    labels = copy.deepcopy(layer.labels)
    with pytest.raises(edit.EditConflict, match="runs along features"):
        edit.delete(layer, [riser, tread])
    assert np.array_equal(labels, layer.labels)


def test_deleting_names_no_feature_or_all_is_an_error(boss):
    layer, _ = boss
    with pytest.raises(ValueError, match="no feature"):
        edit.delete(layer, [len(layer.features)])
    with pytest.raises(ValueError, match="every feature"):
        edit.delete(layer, list(range(len(layer.features))))
