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


def _face_neighbours(F):
    """(#F, 3): the face across each edge of each face (edge k from corner k to k+1), -1 where the
    edge has not exactly two faces."""
    edges = np.sort(np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2), axis=1).astype(np.int64)
    keys = edges[:, 0] * (int(F.max()) + 1) + edges[:, 1]
    order = np.argsort(keys, kind="stable")
    _, start, counts = np.unique(keys[order], return_index=True, return_counts=True)
    pairs = start[counts == 2]
    a, b = order[pairs], order[pairs + 1]
    neighbour = np.full(len(keys), -1, dtype=np.int64)
    neighbour[a], neighbour[b] = b // 3, a // 3
    return neighbour.reshape(-1, 3)


def _absorb(layer, V, F, labels, changed):
    """Changed faces that lie on a kept neighbour's surface join that feature: grown from the faces
    the sculpting left, a changed face joins a feature of a face across one of its edges when its
    three corners and its centre are within the layer's distance tolerance of that feature's surface.
    A bump flattened back into its face becomes that face; the flat ends of a sculpted region stay
    with the faces they continue. Returns the faces absorbed (per face) and updates `labels`."""
    neighbours = _face_neighbours(F)
    tolerance = layer.distance_tolerance
    assigned = labels >= 0
    absorbed = np.zeros(len(F), dtype=bool)
    rejected = set()  # (face, feature) pairs already found off the surface
    while True:
        across = neighbours[changed & ~absorbed]
        faces = np.flatnonzero(changed & ~absorbed)
        candidates = {}
        for k in range(3):
            other = across[:, k]
            ok = other >= 0
            ok[ok] = assigned[other[ok]]
            for f, l in zip(faces[ok].tolist(), labels[other[ok]].tolist()):
                if (f, l) not in rejected and layer.features[l]["type"] != "freeform":
                    candidates.setdefault(l, set()).add(f)
        if not candidates:
            return absorbed
        grew = False
        for feature, members in sorted(candidates.items()):
            members = np.array(sorted(members), dtype=np.int64)
            members = members[~absorbed[members]]
            if not len(members):
                continue
            corners = V[F[members]]
            points = np.concatenate([corners.reshape(-1, 3), corners.mean(axis=1)])
            f = layer.features[feature]
            _, distance = native.onto_surface(f["type"], f["params"], np.ascontiguousarray(points, float))
            near = np.concatenate([distance[:3 * len(members)].reshape(-1, 3), distance[3 * len(members):, None]],
                                  axis=1).max(axis=1) <= tolerance
            labels[members[near]] = feature
            absorbed[members[near]] = assigned[members[near]] = True
            rejected.update((int(m), feature) for m in members[~near])
            grew |= bool(near.any())
        if not grew:
            return absorbed


def _fillet(planes, points, tolerance, near=None):
    """The cylinder tangent to both `planes` (feature dicts, not parallel) that most of `points` lie
    on (thesis 4.3.3: two tangent planes fix a cylinder's axis and, for a radius, its centre).

    Each point votes for the radii of the two such circles through it; the radius with most votes
    within `tolerance` is refined by least squares over the points within `tolerance` of its
    cylinder. A sculpted round has a constant section along most of its length and fades out at its
    ends: the votes find the section, where a least-squares fit over all points would mix in the
    ends. The centre is on the side of each plane where `near` (a point, default the points' mean)
    lies. Returns (params, inliers per point) or None."""
    from scipy.optimize import minimize_scalar
    n = [np.asarray(p["params"]["normal"], float) for p in planes]
    o = [np.asarray(p["params"]["point"], float) for p in planes]
    axis = np.cross(n[0], n[1])
    if np.linalg.norm(axis) < 1e-6:
        return None
    axis /= np.linalg.norm(axis)
    near = points.mean(axis=0) if near is None else near
    line = np.linalg.solve(np.array([n[0], n[1], axis]), np.array([n[0] @ o[0], n[1] @ o[1], axis @ near]))
    sides = np.array([np.sign((near - o[k]) @ n[k]) or 1.0 for k in range(2)])
    c12 = n[0] @ n[1]
    a, b = np.linalg.solve(np.array([[1.0, c12], [c12, 1.0]]), sides)  # centre = line + r (a n0 + b n1)
    offset = a * n[0] + b * n[1]
    across = points - line
    across -= np.outer(across @ axis, axis)

    def distances(r):
        return np.abs(np.linalg.norm(across - r * offset, axis=1) - r)

    # |q - r o|^2 = r^2: (|o|^2 - 1) r^2 - 2 (q.o) r + |q|^2 = 0, two roots per point.
    qa, qo, qq = offset @ offset - 1.0, across @ offset, np.einsum("ij,ij->i", across, across)
    disc = np.sqrt(np.maximum(qo * qo - qa * qq, 0.0))
    votes = np.concatenate([(qo - disc) / qa, (qo + disc) / qa]) if abs(qa) > 1e-9 else qq / (2 * qo)
    votes = votes[np.isfinite(votes) & (votes > tolerance)]
    if not len(votes):
        return None
    bins = np.arange(votes.min(), votes.max() + 2 * tolerance, tolerance)
    counts, edges = np.histogram(votes, bins=bins)
    k = int(np.argmax(counts))
    start = 0.5 * (edges[k] + edges[k + 1])
    inliers = distances(start) <= tolerance
    if inliers.sum() < 3:
        return None
    r = float(minimize_scalar(lambda r: float(np.sum(distances(r)[inliers] ** 2)),
                              bounds=(start - 2 * tolerance, start + 2 * tolerance), method="bounded").x)
    centre = line + r * offset
    inliers = distances(r) <= tolerance
    return {"axis": axis.tolist(), "point": (centre + ((near - centre) @ axis) * axis).tolist(), "radius": r}, inliers


def _semi_defined(layer, V, F, labels, features, count):
    """Region features that meet two kept planes, a new cylinder along both (its axis parallel to
    them within the layer's angle tolerance) or a freeform piece: a sculpted round edge. A cylinder
    becomes the one tangent to both planes (:func:`_fillet`); of a freeform piece, the faces on such a
    cylinder become a new cylinder feature. Returns the new tangent relations."""
    neighbours = _face_neighbours(F)
    sine = np.sin(np.radians(layer.angle_tolerance or 10.0))
    tolerance = layer.distance_tolerance
    relations = []
    for f in list(features[count:]):
        mine = labels == f["id"]
        if f["type"] not in ("cylinder", "freeform") or not mine.any():
            continue
        across = neighbours[mine].ravel()
        across = labels[across[across >= 0]]
        kept, shared = np.unique(across[(across >= 0) & (across < count)], return_counts=True)
        planes = [(c, k) for k, c in zip(kept.tolist(), shared.tolist()) if features[k]["type"] == "plane"]
        if f["type"] == "cylinder":
            axis = np.asarray(f["params"]["axis"], float)
            planes = [(c, k) for c, k in planes if abs(np.asarray(features[k]["params"]["normal"], float) @ axis) <= sine]
        if len(planes) < 2:
            continue
        chosen = [features[k] for _, k in sorted(planes, reverse=True)[:2]]
        vertices = np.unique(F[mine])
        near = np.asarray(f["params"]["point"], float) if f["type"] == "cylinder" else None
        fitted = _fillet(chosen, V[vertices], tolerance, near)
        if fitted is None:
            continue
        params, inliers = fitted
        if f["type"] == "cylinder":
            if np.asarray(params["axis"]) @ np.asarray(f["params"]["axis"]) < 0:
                params.update(axis=(-np.asarray(params["axis"])).tolist())
            f["params"] = params
            target = f["id"]
        else:
            on = np.zeros(len(V), dtype=bool)
            on[vertices[inliers]] = True
            faces = np.flatnonzero(mine & on[F].all(axis=1))
            # A piece of the round needs faces across it: at least as many as the planes' shared edges.
            if len(faces) < max(3, min(c for c, _ in sorted(planes, reverse=True)[:2])):
                continue
            target = len(features)
            features.append({"id": target, "type": "cylinder", "params": params})
            labels[faces] = target
        relations += [{"kind": "tangent", "features": sorted([target, p["id"]])} for p in chosen]
    return relations


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
    rest = changed & ~_absorb(layer, V, F, labels, changed)
    count = len(layer.features)
    features = [dict(f) for f in layer.features]
    relations = [dict(r) for r in layer.relations]
    adjacency_before = {(min(a["a"], a["b"]), max(a["a"], a["b"])): a for a in layer.adjacency}
    sub_adjacency = {}
    if rest.any():
        region = _grow(F, rest, rings)
        used = np.unique(F[region])
        index = np.full(len(V), -1, dtype=np.int64)
        index[used] = np.arange(len(used))
        sub = idealize(Mesh(V[used], index[F[region]]), distance_tolerance=layer.distance_tolerance,
                       angle_tolerance=layer.angle_tolerance or 10.0, measured=True)
        sub_labels = np.asarray(sub.labels)
        region_faces = np.flatnonzero(region)
        around = set(labels[region & ~rest].tolist()) - {-1}
        mapping = {}
        for s in sub.features:
            mine = sub_labels == s["id"]
            points = sub.mesh.vertices[np.unique(sub.mesh.faces[mine])]
            match = [f for f in sorted(around) if _same_surface(layer.features[f], s, points, layer.distance_tolerance)]
            if match:
                mapping[s["id"]] = match[0]
            elif np.any(rest[region_faces[mine]]):
                mapping[s["id"]] = len(features)
                features.append(dict(s, id=len(features)))
        for k, f in enumerate(region_faces):
            if rest[f]:
                labels[f] = mapping.get(int(sub_labels[k]), -1)
        for a in sub.adjacency:
            x, y = mapping.get(a["a"]), mapping.get(a["b"])
            if x is not None and y is not None and x != y:
                sub_adjacency[(min(x, y), max(x, y))] = a
        for r in sub.relations:
            members = sorted({mapping[m] for m in r["features"] if m in mapping})
            if len(members) >= 2 and any(m >= count for m in members):
                relations.append(dict(r, features=members))
    relations += _semi_defined(layer, V, F, labels, features, count)
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
