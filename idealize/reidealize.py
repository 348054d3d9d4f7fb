"""Local re-idealization (thesis ch. 5 and 7; issue 53): after the mesh was sculpted, here or in
another program, only the modified region and a ring around it are segmented and idealized again,
and the result is merged back into the feature layer. Features elsewhere keep their ids and their
parameters exactly.

    sculptor = idealize.sculpt.Sculptor(layer)
    sculptor.stroke("flatten", points, directions, radius=4)
    layer = idealize.reidealize(layer, sculptor.mesh(), sculptor.modified())

Without `modified`, the faces that are not triangles of the layer's idealized mesh (the same three
vertices, to rounding) count as modified: a mesh exported, sculpted elsewhere and read back.

How the region is merged back:

- Faces the sculpting did not change keep their features, in the region's ring too.
- The region is idealized as a mesh of its own (the layer's tolerances). Each feature found there
  is matched to a feature of the layer around it with the same surface where it lies (of the same
  type, within the layer's distance tolerance): a bump flattened back into its face becomes that
  face again, with its parameters unchanged. Features that match none are new, with ids after the
  layer's.
- Vertices of modified faces move onto their feature's surface; vertices that unmodified faces
  share stay where they are, so those faces stay exactly as they were.
- A feature of the layer left without faces keeps its id, with no triangles.
"""
import numpy as np

from . import _native as native
from .features import FeatureLayer, as_feature_layer, idealize
from .mesh import Mesh

# Rings of faces around the modified ones that are idealized with them: one ring gives each
# region feature the faces across its border, a second lets the segmentation see the curvature
# there (its one-ring estimates reach one ring further).
RINGS = 2


def _carried(layer, mesh):
    """Per face of `mesh`: the layer's label of the same triangle (its three vertices at the same
    places, to rounding), or -1."""
    from scipy.spatial import cKDTree
    old = layer.idealized_vertices
    size = float(np.linalg.norm(np.ptp(old, axis=0))) or 1.0
    # A float32 file (an STL) keeps 24 bits: 6e-8 of the coordinates; 1e-6 of the part is well above.
    distance, index = cKDTree(old).query(mesh.vertices, distance_upper_bound=1e-6 * size)
    matched = np.where(np.isfinite(distance), index, -1)
    old_faces = {tuple(sorted(f)): l for f, l in zip(layer.mesh.faces.tolist(), np.asarray(layer.labels).tolist())}
    carried = np.full(len(mesh.faces), -1, dtype=np.int64)
    for i, face in enumerate(matched[mesh.faces].tolist()):
        if min(face) >= 0:
            carried[i] = old_faces.get(tuple(sorted(face)), -1)
    return carried


def _grow(faces, chosen, rings):
    """`chosen` (per face) grown by `rings` rings of faces sharing a vertex."""
    region = chosen.copy()
    for _ in range(rings):
        touched = np.zeros(faces.max() + 1, dtype=bool)
        touched[faces[region].ravel()] = True
        region |= touched[faces].any(axis=1)
    return region


def _same_surface(feature, found, points, tolerance):
    """Whether the layer's `feature` has the surface of the region's feature `found` where it lies:
    the region feature's surface under its `points` (their nearest points on it) within
    `tolerance` of the feature's surface, of the same type."""
    if feature["type"] != found["type"] or feature["type"] == "freeform" or len(points) == 0:
        return False
    on_found, _ = native.onto_surface(found["type"], found["params"], np.ascontiguousarray(points, float))
    _, distance = native.onto_surface(feature["type"], feature["params"], on_found)
    return float(distance.max()) <= tolerance


def reidealize(layer, mesh, modified=None, labels=None, rings=RINGS):
    """A new feature layer for `mesh` (an :class:`idealize.Mesh`, the layer's idealized mesh
    sculpted), re-idealizing only the faces flagged in `modified` (per face of `mesh`; None: the
    faces that are not the layer's triangles) and `rings` rings around them. `labels` (per face,
    optional): the layer's feature of each face that was not modified, as a Sculptor carries them
    (saves finding the layer's triangles in the mesh). The input layer is not modified."""
    layer = as_feature_layer(layer)
    V, F = mesh.vertices, mesh.faces
    if labels is not None and modified is not None:
        carried = np.asarray(labels, dtype=np.int64)
        if carried.shape != (len(F),):
            raise ValueError("one label per face of the mesh (%d faces, %d labels)" % (len(F), len(carried)))
    else:
        carried = _carried(layer, mesh)
    changed = carried < 0
    if modified is not None:
        modified = np.asarray(modified, dtype=bool)
        if modified.shape != (len(F),):
            raise ValueError("one modified flag per face of the mesh (%d faces, %d flags)" % (len(F), len(modified)))
        changed |= modified
    labels = np.where(changed, -1, carried)
    count = len(layer.features)
    features = [dict(f) for f in layer.features]
    relations = [dict(r) for r in layer.relations]
    adjacency_before = {(min(a["a"], a["b"]), max(a["a"], a["b"])): a for a in layer.adjacency}
    sub_adjacency = {}
    if changed.any():
        region = _grow(F, changed, rings)
        used = np.unique(F[region])
        index = np.full(len(V), -1, dtype=np.int64)
        index[used] = np.arange(len(used))
        sub = idealize(Mesh(V[used], index[F[region]]), distance_tolerance=layer.distance_tolerance,
                       angle_tolerance=layer.angle_tolerance or 10.0)
        sub_labels = np.asarray(sub.labels)
        region_faces = np.flatnonzero(region)
        around = set(carried[region & ~changed].tolist()) - {-1}
        mapping = {}
        for s in sub.features:
            mine = sub_labels == s["id"]
            points = sub.mesh.vertices[np.unique(sub.mesh.faces[mine])]
            match = [f for f in sorted(around) if _same_surface(layer.features[f], s, points, layer.distance_tolerance)]
            if match:
                mapping[s["id"]] = match[0]
            elif np.any(changed[region_faces[mine]]):
                mapping[s["id"]] = len(features)
                features.append(dict(s, id=len(features)))
        for k, f in enumerate(region_faces):
            if changed[f]:
                labels[f] = mapping.get(int(sub_labels[k]), -1)
        for a in sub.adjacency:
            x, y = mapping.get(a["a"]), mapping.get(a["b"])
            if x is not None and y is not None and x != y:
                sub_adjacency[(min(x, y), max(x, y))] = a
        for r in sub.relations:
            members = sorted({mapping[m] for m in r["features"] if m in mapping})
            if len(members) >= 2 and any(m >= count for m in members):
                relations.append(dict(r, features=members))
    return _assemble(layer, mesh, labels, changed, features, relations, adjacency_before, sub_adjacency)


def _assemble(layer, mesh, labels, changed, features, relations, adjacency_before, sub_adjacency):
    V, F = mesh.vertices, mesh.faces
    # Vertices of changed faces on one feature only go onto its surface; those that unchanged faces
    # share stay, and so do those on several features' borders.
    fixed = np.zeros(len(V), dtype=bool)
    fixed[F[~changed].ravel()] = True
    idealized = V.copy()
    deviation = np.full(len(V), np.nan)
    # How many features each vertex's faces have, and whether a changed face has it.
    width = len(features) + 1  # (vertex, label) pairs as one key each: a 1-d unique is fast
    keys = np.unique(F.ravel().astype(np.int64) * width + (np.repeat(labels, 3) + 1))
    pairs = np.stack([keys // width, keys % width - 1], axis=1)
    pairs = pairs[pairs[:, 1] >= 0]
    on_features = np.bincount(pairs[:, 0], minlength=len(V))
    in_changed = np.zeros(len(V), dtype=bool)
    in_changed[F[changed].ravel()] = True
    movable = (on_features == 1) & in_changed & ~fixed
    for f in features:
        vertices = pairs[pairs[:, 1] == f["id"], 0]
        if len(vertices) == 0 or f["type"] == "freeform":
            continue
        closest, distance = native.onto_surface(f["type"], f["params"], np.ascontiguousarray(V[vertices], float))
        deviation[vertices] = np.fmax(deviation[vertices], distance)
        move = movable[vertices]
        idealized[vertices[move]] = closest[move]
        deviation[vertices[move]] = 0.0
    # The graph from the faces now: the layer's edges where they remain, the region's new ones.
    edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1).astype(np.int64)
    edge_keys = edges[:, 0] * len(V) + edges[:, 1]
    owner = np.tile(labels, 3)
    order = np.argsort(edge_keys, kind="stable")
    edge_keys, owner = edge_keys[order], owner[order]
    same = edge_keys[1:] == edge_keys[:-1]
    pairs = set()
    for a, b in zip(owner[:-1][same].tolist(), owner[1:][same].tolist()):
        if a != b and a >= 0 and b >= 0:
            pairs.add((min(a, b), max(a, b)))
    adjacency = [adjacency_before.get(p) or dict(sub_adjacency.get(p, {"continuity": "G0", "angle": 0.0, "length": 0.0}),
                                                  a=p[0], b=p[1]) for p in sorted(pairs)]
    present = {f["id"] for f in features}
    relations = [r for r in relations if all(m in present for m in r["features"])]
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    areas = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    valid = labels >= 0
    area = np.bincount(labels[valid], weights=areas[valid], minlength=len(features))
    triangles = np.bincount(labels[valid], minlength=len(features))
    for f in features:
        f["area"], f["triangles"] = float(area[f["id"]]), int(triangles[f["id"]])
    finite = deviation[np.isfinite(deviation)]
    result = {
        "labels": labels.astype(np.int32), "features": features, "adjacency": adjacency, "relations": relations,
        "idealized_vertices": idealized, "vertex_deviation": deviation,
        "max_deviation": float(finite.max()) if finite.size else 0.0,
        "rms_deviation": float(np.sqrt(np.mean(finite ** 2))) if finite.size else 0.0,
        "distance_tolerance": layer.distance_tolerance, "form_deviation": layer.form_deviation,
        "mesh_kind": layer.mesh_kind, "angle_tolerance_degrees": layer.angle_tolerance,
        "noise": layer.noise, "normal_noise": layer.normal_noise, "timings": []}
    out = FeatureLayer(Mesh(V, F, source=getattr(mesh, "source", None)), None, result)
    out.changed_faces = changed
    return out
