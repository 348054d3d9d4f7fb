"""Clay-like sculpting of a mesh (thesis ch. 5; issue 53): brushes applied along strokes, with
dynamic topology so that the triangles stay well shaped however far the surface is pushed.

Brushes: ``draw`` (raise along the area's normal; a negative strength digs), ``inflate`` (along
each vertex's normal), ``flatten`` (towards the area's mean plane), ``smooth``, ``pinch``
(towards the stroke), ``crease`` (pinch and dig) and ``grab`` (the area under the first point
follows the stroke). Each stroke is a list of points on the surface and the view direction at each
(into the scene: faces turned away from the viewer are left alone); dabs are placed every
``spacing`` times the radius along it. See native/src/sculpt/brushes.h for the exact rules.

One stroke::

    mesh, modified = idealize.sculpt.stroke(layer, "draw", points, directions, radius=4, strength=0.5)

Many strokes on one mesh (the half-edge structure is built once)::

    sculptor = idealize.sculpt.Sculptor(layer)
    sculptor.stroke("flatten", points, directions, radius=4)
    mesh, modified = sculptor.mesh(), sculptor.modified()
"""
import numpy as np

from . import _native as native
from .features import as_feature_layer
from .mesh import Mesh

BRUSHES = ("draw", "inflate", "flatten", "smooth", "pinch", "crease", "grab")


def _mesh_and_labels(layer_or_mesh):
    """(vertices, faces, labels): a layer's idealized mesh and feature labels, or a mesh's with
    none (-1)."""
    if isinstance(layer_or_mesh, Mesh):
        return layer_or_mesh.vertices, layer_or_mesh.faces, None
    layer = as_feature_layer(layer_or_mesh)
    return layer.idealized_vertices, layer.mesh.faces, np.asarray(layer.labels, dtype=np.int64)


def _points(array, name):
    array = np.ascontiguousarray(np.asarray(array, dtype=np.float64).reshape(-1, 3))
    if not np.all(np.isfinite(array)):
        raise ValueError("the stroke's %s must be finite numbers" % name)
    return array


class Sculptor:
    """A mesh (or a feature layer's idealized mesh) being sculpted stroke by stroke. The input is
    never modified. Faces carry the feature label of the face they came from; ``modified()`` says
    which faces strokes changed since ``clear_marks()``."""

    def __init__(self, layer_or_mesh):
        vertices, faces, labels = _mesh_and_labels(layer_or_mesh)
        self._native = native.Sculptor(np.ascontiguousarray(vertices, dtype=np.float64),
                                       np.ascontiguousarray(faces, dtype=np.int32),
                                       [] if labels is None else labels.tolist())
        self._snapshot = None

    def stroke(self, brush, points, directions=None, radius=1.0, strength=0.5, spacing=0.2, target_edge_length=0.0,
               dynamic_topology=True):
        """Applies `brush` along the stroke `points` (S x 3) seen along `directions` (S x 3, or
        None: from every side). `radius` in the mesh's units (> 0); `strength` per unit of stroke
        length (see the module's doc); `target_edge_length` 0 keeps the resolution under the first
        point. Returns dict(dabs, moved_vertices, target_edge_length)."""
        if brush not in BRUSHES:
            raise ValueError("unknown brush %r: %s" % (brush, ", ".join(BRUSHES)))
        points = _points(points, "points")
        directions = np.zeros((0, 3)) if directions is None else _points(directions, "directions")
        if len(points) == 0:
            raise ValueError("a stroke needs at least one point")
        if len(directions) not in (0, len(points)):
            raise ValueError("one view direction per stroke point (%d points, %d directions)"
                             % (len(points), len(directions)))
        self._snapshot = None
        return dict(self._native.stroke(brush, points, directions, radius=float(radius), strength=float(strength),
                                        spacing=float(spacing), target_edge_length=float(target_edge_length),
                                        dynamic_topology=bool(dynamic_topology)))

    def _state(self):
        if self._snapshot is None:
            self._snapshot = self._native.mesh()
        return self._snapshot

    def mesh(self):
        """The sculpted mesh (an idealize.Mesh)."""
        state = self._state()
        return Mesh(state["V"], state["F"])

    def labels(self):
        """Per face of mesh(): the feature label of the face it came from (-1 for none)."""
        return np.asarray(self._state()["labels"], dtype=np.int64)

    def modified(self):
        """Per face of mesh(): whether a stroke changed it since clear_marks()."""
        return np.asarray(self._state()["modified"], dtype=bool)

    def clear_marks(self):
        self._native.clear_marks()
        self._snapshot = None


def sculpt(layer, strokes):
    """Sculpts a feature layer's idealized mesh with `strokes` (dicts with the arguments of
    Sculptor.stroke: brush, points, directions, radius, strength, spacing), then re-idealizes what
    they changed (:func:`idealize.reidealize`). Returns the new layer; the input is not modified.
    This is the ``{"op": "sculpt", "strokes": [...]}`` edit of :func:`idealize.edit.apply`, as a
    document stores it."""
    from .reidealize import reidealize
    layer = as_feature_layer(layer)
    if not strokes:
        raise ValueError("sculpting needs at least one stroke")
    sculptor = Sculptor(layer)
    for number, one in enumerate(strokes):
        one = dict(one)
        unknown = set(one) - {"brush", "points", "directions", "radius", "strength", "spacing"}
        if unknown or "brush" not in one or "points" not in one:
            raise ValueError("stroke %d: needs brush and points, takes directions, radius, strength and spacing "
                             "(unknown: %s)" % (number + 1, sorted(unknown)))
        sculptor.stroke(one.pop("brush"), one.pop("points"), one.pop("directions", None), **one)
    return reidealize(layer, sculptor.mesh(), sculptor.modified(), labels=sculptor.labels())


def stroke(layer_or_mesh, brush, points, directions=None, radius=1.0, strength=0.5, spacing=0.2):
    """One stroke of `brush` on a feature layer's idealized mesh or on a mesh (see Sculptor.stroke).
    Returns (the new idealize.Mesh, modified: per face of it, whether the stroke changed it)."""
    sculptor = Sculptor(layer_or_mesh)
    sculptor.stroke(brush, points, directions, radius=radius, strength=strength, spacing=spacing)
    return sculptor.mesh(), sculptor.modified()


__all__ = ["BRUSHES", "Sculptor", "sculpt", "stroke"]
