"""Honest validity of the B-rep (issue 49): a solid is a solid only where it lies on its mesh."""
import numpy as np
import pytest

import idealize
import shapes
from idealize._loader import native
from idealize.mesh import Mesh
from test_brep import box, box_with_hole, drilled_block

needs_freecad = pytest.mark.skipif(shapes.freecad() is None, reason="FreeCAD is not installed")


def enclosed_volume(V, F):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0


def plane_params(face, shift=0.0):
    """A planar face's plane, moved `shift` along its outward normal."""
    normal = np.array(face.normalAt(0, 0))
    point = np.array(face.Surface.Position) + shift * normal
    return {"normal": tuple(normal), "point": tuple(point)}


@needs_freecad
@pytest.mark.parametrize("make", [box, box_with_hole, drilled_block])
def test_a_solid_lies_within_its_stated_deviation_of_its_mesh(make):
    part = make()
    V, F, _ = shapes.tessellate_with_faces(part, 0.05)
    solid = idealize.make_solid(idealize.idealize(Mesh(V, F)))
    assert solid.solid, solid.problems
    report = solid.report()
    deviation = report["deviation"]
    assert 0.0 <= deviation["mesh_to_solid"] <= deviation["bound"]
    assert 0.0 <= deviation["solid_to_mesh"] <= deviation["bound"]
    # A CAD tessellation's faces lie on the part's: the bound is the chord's sagitta and tolerance.
    assert deviation["bound"] < 0.01 * part.BoundBox.DiagonalLength
    assert report["mesh_volume"] == pytest.approx(enclosed_volume(V, F), rel=1e-9)
    assert solid.volume == pytest.approx(report["mesh_volume"], rel=1e-3)


@needs_freecad
def test_a_face_whose_plane_lies_off_its_mesh_is_not_kept_as_that_plane():
    """A box whose top plane was fitted 2 mm below its triangles (of 20) makes a valid closed solid
    of a lower box, which OpenCASCADE's checks accept. It is not the mesh's solid: the top region
    lies off it as a whole. The top becomes its own triangles, the sides stay planes, and the
    solid is the mesh's box. (A uniform mesh: on the 12 triangles of a tessellation, half of each
    side's vertices lie on the top edge, and each side lies off the lower box as much as the top.)"""
    part = box()
    V, F, face, _ = shapes.uniform_remesh(part, 4000)
    top = max(range(len(part.Faces)), key=lambda i: part.Faces[i].CenterOfMass.z)
    params = [plane_params(f, -2.0 if i == top else 0.0) for i, f in enumerate(part.Faces)]
    brep = native.build_brep(V, F, face, ["plane"] * len(part.Faces), params)
    assert brep.solid and brep.valid and brep.closed
    kinds = {r["feature"]: r for r in brep.regions}
    assert kinds[top]["kind"] == "faceted" and "off the solid" in kinds[top]["reason"]
    assert all(r["kind"] == "analytic" for feature, r in kinds.items() if feature != top)
    assert brep.volume == pytest.approx(part.Volume, rel=0.01)  # the lowered box: 10 % less
    assert brep.mesh_to_shape <= brep.deviation_bound and brep.shape_to_mesh <= brep.deviation_bound


@needs_freecad
def test_an_open_mesh_states_no_deviation():
    """An open shell is never a solid: its deviation and volume are not measured (0)."""
    part = box()
    V, F, face = shapes.tessellate_with_faces(part, 0.05)
    top = max(range(len(part.Faces)), key=lambda i: part.Faces[i].CenterOfMass.z)
    keep = face != top
    params = [plane_params(f) for f in part.Faces]
    brep = native.build_brep(V, F[keep], face[keep], ["plane"] * len(part.Faces), params)
    assert not brep.solid and not brep.closed
    assert brep.mesh_volume == 0.0 and brep.deviation_bound == 0.0


@needs_freecad
def test_a_region_its_neighbour_explains_joins_it():
    """Two triangles of a bore's tessellation labelled as planes of their own (the one-triangle
    planes a feature layer leaves along a CAD export's rounded edges): their vertices lie on the
    cylinder and their middles within its sagitta, so the cylinder explains them as well as their
    planes do. They join it before any geometry is made, and every face is analytic (before, they
    became facets). A step or a disc that only touches a neighbour's surface along its border stays
    (the round trips of test_brep keep them)."""
    part = box_with_hole()
    V, F, _ = shapes.tessellate_with_faces(part, 0.05)
    layer = idealize.idealize(Mesh(V, F))
    labels = np.asarray(layer.labels, dtype=np.int32).copy()
    types = [f["type"] for f in layer.features]
    params = [dict(f["params"]) for f in layer.features]
    cylinder = types.index("cylinder")
    triangles = np.flatnonzero(labels == cylinder)
    oriented = np.asarray(layer.oriented_faces)
    for t in triangles[[0, len(triangles) // 3]]:
        a, b, c = V[oriented[t]]
        normal = np.cross(b - a, c - a)
        types.append("plane")
        params.append({"normal": tuple(normal / np.linalg.norm(normal)), "point": tuple((a + b + c) / 3)})
        labels[t] = len(types) - 1
    brep = native.build_brep(V, oriented, labels, types, params, layer.distance_tolerance)
    assert brep.solid and brep.surface_types == {"cylinder": 1, "plane": 6}
    assert all(r["kind"] == "analytic" for r in brep.regions)
    slivers = set(range(len(layer.features), len(types)))
    assert not slivers & {r["feature"] for r in brep.regions}
    assert set(brep.joined) == {(feature, cylinder) for feature in slivers}
    assert brep.volume == pytest.approx(part.Volume, rel=1e-3)
