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
from .mesh import Mesh, MeshError

BRUSHES = ("draw", "inflate", "flatten", "smooth", "pinch", "crease", "grab")


def _mesh_and_labels(layer_or_mesh):
    """(vertices, faces, labels): a layer's idealized mesh (its faces with the segmentation's
    orientation repair) and feature labels, or a mesh's with none (-1)."""
    if isinstance(layer_or_mesh, Mesh):
        return layer_or_mesh.vertices, layer_or_mesh.faces, None
    layer = as_feature_layer(layer_or_mesh)
    return layer.idealized_vertices, np.asarray(layer.oriented_faces), np.asarray(layer.labels, dtype=np.int64)


def split_where_not_manifold(vertices, faces):
    """(vertices, faces) with the mesh cut apart where it is not a consistently oriented manifold, so
    that a half-edge structure holds it: an edge of more than two faces, or of two faces that run
    along it the same way, joins none of them, and a vertex whose faces make several fans (joined
    across such edges) gets a copy of itself for each fan after the first. No face is lost or moved:
    the mesh gets borders where it was cut. The input is not modified."""
    F = np.asarray(faces, dtype=np.int64)
    count = len(F)
    corner = np.arange(3 * count).reshape(-1, 3)
    heads, tails = F, np.roll(F, -1, axis=1)
    key = np.minimum(heads, tails).ravel() * (int(F.max()) + 1 if count else 1) + np.maximum(heads, tails).ravel()
    order = np.argsort(key, kind="stable")
    _, start, sizes = np.unique(key[order], return_index=True, return_counts=True)
    first, second = order[start[sizes == 2]], order[start[sizes == 2] + 1]  # half-edges, as face * 3 + k
    forward = heads.ravel()
    opposite = forward[first] != forward[second]  # the two faces run along the edge in turn
    first, second = first[opposite], second[opposite]
    # Across a shared edge a -> b (in the first face) and b -> a (in the second), the corners at a
    # are one vertex, and so are those at b.
    at_a = (first, second // 3 * 3 + (second % 3 + 1) % 3)
    at_b = (first // 3 * 3 + (first % 3 + 1) % 3, second)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    rows = np.concatenate([at_a[0], at_b[0]])
    cols = np.concatenate([at_a[1], at_b[1]])
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(3 * count, 3 * count))
    _, fan = connected_components(graph, directed=False)
    original = forward  # the vertex of each corner
    fans, first_corner = np.unique(fan, return_index=True)
    fan_vertex = original[first_corner]
    # The first fan of each vertex keeps its index; the others are copies appended in fan order.
    order = np.lexsort((fans, fan_vertex))
    keeps = np.ones(len(fans), dtype=bool)
    keeps[order[1:]] = fan_vertex[order[1:]] != fan_vertex[order[:-1]]
    index = np.empty(len(fans), dtype=np.int64)
    index[keeps] = fan_vertex[keeps]
    extra = np.flatnonzero(~keeps)
    index[extra] = len(vertices) + np.arange(len(extra))
    V = np.concatenate([np.asarray(vertices, dtype=np.float64), np.asarray(vertices, dtype=np.float64)[fan_vertex[extra]]])
    lookup = np.empty(fan.max() + 1 if count else 0, dtype=np.int64)
    lookup[fans] = index
    return V, lookup[fan[corner]]


def _points(array, name):
    array = np.ascontiguousarray(np.asarray(array, dtype=np.float64).reshape(-1, 3))
    if not np.all(np.isfinite(array)):
        raise ValueError("the stroke's %s must be finite numbers" % name)
    return array


def _stroke_points(points, directions, empty=False):
    points = _points(points, "points")
    directions = np.zeros((0, 3)) if directions is None else _points(directions, "directions")
    if len(points) == 0 and not empty:
        raise ValueError("a stroke needs at least one point")
    if len(directions) not in (0, len(points)):
        raise ValueError("one view direction per stroke point (%d points, %d directions)"
                         % (len(points), len(directions)))
    return points, directions


class Sculptor:
    """A mesh (or a feature layer's idealized mesh) being sculpted stroke by stroke. The input is
    never modified. Faces carry the feature label of the face they came from; ``modified()`` says
    which faces strokes changed since ``clear_marks()``.

    A mesh that is not a consistently oriented manifold (a real scan's or export's: edges of more
    than two faces, fans touching at a vertex) is cut apart there first
    (:func:`split_where_not_manifold`; ``repaired`` says so): every face is kept, and a stroke across
    such a cut moves its two sides apart as far as they are apart in the brush's reach."""

    def __init__(self, layer_or_mesh):
        vertices, faces, labels = _mesh_and_labels(layer_or_mesh)
        labels = [] if labels is None else labels.tolist()
        self.repaired = False
        try:
            self._native = native.Sculptor(np.ascontiguousarray(vertices, dtype=np.float64),
                                           np.ascontiguousarray(faces, dtype=np.int32), labels)
        except MeshError:
            vertices, faces = split_where_not_manifold(vertices, faces)
            self._native = native.Sculptor(np.ascontiguousarray(vertices, dtype=np.float64),
                                           np.ascontiguousarray(faces, dtype=np.int32), labels)
            self.repaired = True
        self._snapshot = None
        self._open = None  # the native stroke under way (begin ... end)

    def stroke(self, brush, points, directions=None, radius=1.0, strength=0.5, spacing=0.2, target_edge_length=0.0,
               dynamic_topology=True):
        """Applies `brush` along the stroke `points` (S x 3) seen along `directions` (S x 3, or
        None: from every side). `radius` in the mesh's units (> 0); `strength` per unit of stroke
        length (see the module's doc); `target_edge_length` 0 keeps the resolution under the first
        point. Returns dict(dabs, moved_vertices, target_edge_length). The same as begin() at the
        first point, extend() through the others, end()."""
        points, directions = _stroke_points(points, directions)
        self.begin(brush, points[0], None if len(directions) == 0 else directions[0], radius=radius,
                   strength=strength, spacing=spacing, target_edge_length=target_edge_length,
                   dynamic_topology=dynamic_topology)
        self.extend(points[1:], None if len(directions) == 0 else directions[1:])
        return self.end()

    def begin(self, brush, point, direction=None, radius=1.0, strength=0.5, spacing=0.2, target_edge_length=0.0,
              dynamic_topology=True):
        """Starts a stroke at `point` (3,) seen along `direction` (3,; None: from every side), with
        its first dab; the arguments as stroke()'s. For sculpting as the pointer moves: extend()
        with each new point, end() on release. The dabs are those of stroke() with all the points."""
        if brush not in BRUSHES:
            raise ValueError("unknown brush %r: %s" % (brush, ", ".join(BRUSHES)))
        if self._open is not None:
            raise RuntimeError("a stroke is under way: end() it first")
        point = _points(point, "points")
        if len(point) != 1:
            raise ValueError("a stroke begins at one point")
        direction = np.zeros(3) if direction is None else _points(direction, "directions")[0]
        self._snapshot = None
        self._open = native.Stroke(self._native, brush, point[0], direction, radius=float(radius),
                                   strength=float(strength), spacing=float(spacing),
                                   target_edge_length=float(target_edge_length),
                                   dynamic_topology=bool(dynamic_topology))

    def extend(self, points, directions=None):
        """Continues the stroke under way through `points` (S x 3) seen along `directions` (S x 3,
        or None: from every side): the dabs on the way."""
        if self._open is None:
            raise RuntimeError("no stroke is under way: begin() one first")
        points, directions = _stroke_points(points, directions, empty=True)
        self._snapshot = None
        self._open.extend(points, directions)

    def end(self):
        """Ends the stroke under way. Returns dict(dabs, moved_vertices, target_edge_length)."""
        if self._open is None:
            raise RuntimeError("no stroke is under way")
        stroke, self._open = self._open, None
        self._snapshot = None
        return dict(stroke.finish())

    def first_hit(self, origin, direction):
        """Where the ray from `origin` (3,) along `direction` (3,) first meets the mesh as it is now
        (front or back faces), as a (3,) array, or None: a view's picking on the clay."""
        hit = self._native.first_hit(_points(origin, "ray")[0], _points(direction, "ray")[0])
        return None if hit is None else np.asarray(hit, dtype=float)

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


__all__ = ["BRUSHES", "Sculptor", "sculpt", "split_where_not_manifold", "stroke"]
