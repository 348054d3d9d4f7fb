"""Local re-idealization (thesis ch. 5 and 7; issue 53): after the mesh was sculpted, here or in
another program, only the modified region and a ring around it are segmented and idealized again,
and the result is merged back into the feature layer. Features elsewhere keep their ids and their
parameters exactly.

    sculptor = idealize.sculpt.Sculptor(layer)
    sculptor.stroke("flatten", points, directions, radius=4)
    layer = idealize.reidealize(layer, sculptor.mesh(), sculptor.modified())

Without `modified`, the faces that are not triangles of the layer's idealized mesh (the same three
vertices, to rounding) count as modified: a mesh exported, sculpted elsewhere and read back.

How the region is merged back (docs/sculpting.md, section 4):

- Faces the sculpting did not change keep their features, in the region's ring too.
- Changed faces on the surface of a kept feature across one of their edges join it first, grown
  from the faces the sculpting left: a bump flattened back into its face becomes that face.
- The rest is idealized as a mesh of its own (the layer's tolerances, as a measured mesh). Each
  feature found there is matched to a feature of the layer around it with the same surface where it
  lies; features that match none are new, with ids after the layer's.
- New features are made ideal against the kept ones (the thesis's semi-defined features): their
  directions snap to the kept features', planes, cylinders and spheres are refitted to their inner
  vertices, a round between two kept planes becomes the cylinder tangent to both, and freeform
  pieces that no B-spline fits are dissolved into their neighbours.
- Vertices of modified faces move onto their feature's surface; vertices that unmodified faces
  share stay where they are, so those faces stay exactly as they were.
- A feature of the layer left without faces keeps its id, with no triangles.
"""
import numpy as np

from . import _native as native
from .features import FeatureLayer, as_feature_layer, idealize
from .mesh import Mesh
from .segmentation import segment

# Rings of faces around the modified ones that are idealized with them: one ring gives each
# region feature the faces across its border, a second lets the segmentation see the curvature
# there (its one-ring estimates reach one ring further).
RINGS = 2
# The fewest inner vertices a new feature is refitted to (_refit_inside): five times the four
# parameters of a sphere, the most that refit finds, leave its fit determined with noise.
MIN_REFIT_POINTS = 20
# Gauss-Newton steps of a circle or sphere fit from the algebraic one, which on points of a sculpted
# surface is within a few per cent: each step squares the relative error.
GAUSS_NEWTON_STEPS = 6


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


def _region_neighbours(F, near):
    """:func:`_face_neighbours` for the changed faces, from `near` (per face: the changed faces and
    the one ring around them, which holds their neighbours; the ring's own neighbours outside it are
    left -1): the edges of the whole mesh need not be sorted for a local change."""
    near = np.flatnonzero(near)
    neighbours = np.full((len(F), 3), -1, dtype=np.int64)
    if len(near):
        local = _face_neighbours(F[near])
        neighbours[near] = np.where(local >= 0, near[np.maximum(local, 0)], -1)
    return neighbours


def _absorb(features, growing, tolerance, V, F, labels, candidates, neighbours):
    """Grows the features `growing` (ids into `features`) over the `candidates` faces (per face): a
    candidate face joins a growing feature of a face across one of its edges when its three corners
    and its centre are within `tolerance` of that feature's surface (where two such features meet,
    the one of lower id first). `neighbours`: :func:`_face_neighbours` (at least for the candidate
    faces). Returns the faces that joined (per face) and updates `labels`."""
    faces = np.flatnonzero(candidates)
    growing = sorted(growing)
    corners = V[F[faces]]
    points = np.ascontiguousarray(np.concatenate([corners.reshape(-1, 3), corners.mean(axis=1)]), float)
    on = {}
    for feature in growing:
        f = features[feature]
        _, distance = native.onto_surface(f["type"], f["params"], points)
        on[feature] = np.concatenate([distance[:3 * len(faces)].reshape(-1, 3), distance[3 * len(faces):, None]],
                                     axis=1).max(axis=1) <= tolerance
    joined = np.zeros(len(F), dtype=bool)
    local = np.zeros(len(faces), dtype=bool)  # joined, per candidate face
    across = neighbours[faces]
    while True:
        across_labels = np.where(across >= 0, labels[np.maximum(across, 0)], -1)
        grew = False
        for feature in growing:
            joins = ~local & on[feature] & (across_labels == feature).any(axis=1)
            if joins.any():
                local |= joins
                labels[faces[joins]] = feature
                grew = True
        if not grew:
            break
    joined[faces[local]] = True
    return joined


def _absorb_into_kept(layer, V, F, labels, changed, neighbours):
    """Changed faces that lie on a kept neighbour's surface join that feature (:func:`_absorb`, with
    the layer's distance tolerance), grown from the faces the sculpting left. A bump flattened back
    into its face becomes that face; the flat ends of a sculpted region stay with the faces they
    continue. Returns the faces absorbed (per face) and updates `labels`."""
    across = neighbours[changed]
    seen = labels[across[across >= 0]]
    kept = {int(l) for l in seen[seen >= 0]} - {i for i, f in enumerate(layer.features) if f["type"] == "freeform"}
    return _absorb(layer.features, kept, layer.distance_tolerance, V, F, labels, changed, neighbours)


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


def _semi_defined(layer, V, F, labels, features, count, neighbours):
    """Region features that meet two kept planes, a new cylinder along both (its axis parallel to
    them within the layer's angle tolerance) or a freeform piece: a sculpted round edge. A cylinder
    becomes the one tangent to both planes (:func:`_fillet`); of a freeform piece, the faces on such a
    cylinder become a new cylinder feature. Returns the new tangent relations."""
    sine = np.sin(np.radians(layer.angle_tolerance or 10.0))
    tolerance = layer.distance_tolerance
    relations, rounds = [], []
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
        rounds.append(target)
    if rounds:
        # Pieces of the round that the region's segmentation took for other new surfaces (a flat band
        # where the sculpt is not quite round) join it where they lie on it.
        _absorb(features, rounds, tolerance, V, F, labels, (labels >= count) & ~np.isin(labels, rounds), neighbours)
    return relations


def _ball(points, weights):
    """The weighted least-squares circle (n, 2 points) or sphere (n, 3) of the distances: the
    algebraic fit (Kasa), then Gauss-Newton steps. (centre, radius)."""
    w = np.sqrt(weights / weights.sum())
    A = np.column_stack([2 * points, np.ones(len(points))]) * w[:, None]
    solution, *_ = np.linalg.lstsq(A, (points ** 2).sum(axis=1) * w, rcond=None)
    centre = solution[:-1]
    radius = float(np.sqrt(max(solution[-1] + centre @ centre, 0.0)))
    for _ in range(GAUSS_NEWTON_STEPS):
        d = points - centre
        r = np.maximum(np.linalg.norm(d, axis=1), 1e-300)
        J = np.column_stack([-d / r[:, None], -np.ones(len(r))]) * w[:, None]
        step, *_ = np.linalg.lstsq(J, -(r - radius) * w, rcond=None)
        centre, radius = centre + step[:-1], radius + step[-1]
    return centre, float(radius)


def _snap_directions(layer, features, count):
    """The directions of the region's new planes and cylinders (normals, axes) that are within the
    layer's angle tolerance of a kept feature's become that direction exactly: the idealization's
    snapping to the part's ideal directions (thesis 4.3.1), with the kept features as the part. A
    groove dug along a face gets its axis parallel to the face. (Their positions are refitted about
    the new direction next; cones and tori, which are not, keep theirs.)
    Returns {new feature id: the kept features it is now parallel to} (those within the angle
    tolerance of the direction it took, as the idealization made them parallel)."""
    kept, owners = [], []
    for f in features[:count]:
        key = "normal" if f["type"] == "plane" else "axis"
        if key in f.get("params", {}):
            kept.append(np.asarray(f["params"][key], float))
            owners.append(f["id"])
    if not kept:
        return {}
    kept = np.array(kept)
    kept /= np.linalg.norm(kept, axis=1)[:, None]
    cosine = np.cos(np.radians(layer.angle_tolerance or 10.0))
    snapped = {}
    for f in features[count:]:
        if f["type"] not in ("plane", "cylinder"):  # the two that _refit_inside refits about it
            continue
        key = "normal" if f["type"] == "plane" else "axis"
        direction = np.asarray(f["params"][key], float)
        dots = kept @ (direction / np.linalg.norm(direction))
        k = int(np.argmax(np.abs(dots)))
        if abs(dots[k]) >= cosine:
            f["params"] = dict(f["params"], **{key: (np.sign(dots[k]) * kept[k]).tolist()})
            snapped[f["id"]] = [owners[j] for j in np.flatnonzero(np.abs(kept @ kept[k]) >= cosine)]
    return snapped


def _join_parallel(relations, snapped):
    """The relations with each snapped new feature parallel to the kept features it took its
    direction from: groups of parallel features that share a member become one group, in the place
    of the first of them (the layer's other relations keep their order)."""
    out, groups = [], []  # groups: the places in `out` of the parallel groups

    def join(relation):
        members = set(relation["features"])
        hits = [k for k in groups if out[k] is not None and members & set(out[k]["features"])]
        for k in hits:
            members |= set(out[k]["features"])
        if not hits:
            groups.append(len(out))
            out.append(dict(relation, features=sorted(members)))
            return
        out[hits[0]] = dict(out[hits[0]], features=sorted(members))
        for k in hits[1:]:
            out[k] = None

    for r in relations:
        if r["kind"] == "parallel":
            join(r)
        else:
            out.append(r)
    for new, kept in sorted(snapped.items()):
        join({"kind": "parallel", "features": sorted(set(kept) | {new})})
    return [r for r in out if r is not None and len(r["features"]) >= 2]


def _per_vertex(F, faces, values):
    """The vertices of `faces` (indices into F) and, per vertex, the sum of `values` (one per face
    of `faces`: numbers, or rows) over its faces among them."""
    vertices, index = np.unique(F[faces], return_inverse=True)
    values = np.asarray(values, dtype=float)
    sums = np.zeros((len(vertices),) + values.shape[1:])
    np.add.at(sums, index.ravel(), np.repeat(values, 3, axis=0))
    return vertices, sums


def _refit_inside(V, F, labels, features, count, near):
    """New features of the region refitted to their inner vertices, those on no other feature's
    face: a sculpted feature's border is a transition rounded by the brushes (the rim of a groove,
    the foot of a dome), which pulls a fit over all its vertices off the surface the rest follows.
    Directions stay as the region's idealization made them (a cylinder's axis, a plane's normal,
    snapped to the part's directions): a cylinder gets its section's circle, a plane its offset, a
    sphere its centre and radius; cones and tori stay. Only where the inner vertices are at least a
    third of them (a narrow feature has few) and MIN_REFIT_POINTS. `near`: the faces of the new
    features and one ring around them (per face), which hold every face of their vertices."""
    faces = np.flatnonzero(near)
    a, b, c = V[F[faces, 0]], V[F[faces, 1]], V[F[faces, 2]]
    areas = np.zeros(len(F))
    areas[faces] = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    width = len(features) + 1
    keys = np.unique(F[faces].ravel().astype(np.int64) * width + (np.repeat(labels[faces], 3) + 1))
    owners = np.bincount(keys // width, minlength=len(V))  # the features of each vertex's faces
    for f in features[count:]:
        mine = faces[labels[faces] == f["id"]]
        if f["type"] not in ("plane", "cylinder", "sphere") or not len(mine):
            continue
        vertices, weights = _per_vertex(F, mine, areas[mine])
        inside = owners[vertices] == 1
        if inside.sum() < max(MIN_REFIT_POINTS, len(vertices) / 3.0):
            continue
        P, w = V[vertices[inside]], weights[inside]
        params = dict(f["params"])
        if f["type"] == "plane":
            normal = np.asarray(params["normal"], float)
            centre = (P * w[:, None]).sum(axis=0) / w.sum()
            params["point"] = (np.asarray(params["point"], float) + ((centre - params["point"]) @ normal) * normal).tolist()
        elif f["type"] == "cylinder":
            axis = np.asarray(params["axis"], float)
            u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
            u /= np.linalg.norm(u)
            v = np.cross(axis, u)
            origin = np.asarray(params["point"], float)
            centre, radius = _ball(np.column_stack([(P - origin) @ u, (P - origin) @ v]), w)
            params.update(point=(origin + centre[0] * u + centre[1] * v).tolist(), radius=radius)
        else:
            centre, radius = _ball(P, w)
            params.update(center=centre.tolist(), radius=radius)
        f["params"] = params


def _dissolve_folded(V, F, labels, features, count, neighbours):
    """New freeform pieces of the region that no B-spline surface fits (they fold over their mean
    plane: the B-rep would facet them) are dissolved into the features around them: grown from
    their border, each face joins the feature across one of its edges whose surface is nearest its
    centre. Such a piece is where a sculpted surface turns a corner (a round edge ending at a
    face): the ideal is the corner of the surfaces that meet there."""
    for f in features[count:]:
        mine = np.flatnonzero(labels == f["id"]) if f["type"] == "freeform" else []
        if not len(mine):
            continue
        a, b, c = V[F[mine, 0]], V[F[mine, 1]], V[F[mine, 2]]
        normals, centres = np.zeros((len(F), 3)), np.zeros((len(F), 3))
        normals[mine], centres[mine] = np.cross(b - a, c - a), (a + b + c) / 3.0
        vertices, vertex_normals = _per_vertex(F, mine, normals[mine])
        vertex_normals /= np.maximum(np.linalg.norm(vertex_normals, axis=1), 1e-300)[:, None]
        if native.fit_bspline_surface(np.ascontiguousarray(V[vertices], float), vertex_normals,
                                      np.ones(len(vertices)))["valid"]:
            continue
        left = set(mine.tolist())
        while left:
            best = {}
            for face in left:
                for other in neighbours[face]:
                    l = labels[other] if other >= 0 else -1
                    if other in left or l < 0 or features[l]["type"] == "freeform":
                        continue
                    _, d = native.onto_surface(features[l]["type"], features[l]["params"], centres[face][None, :])
                    if face not in best or d[0] < best[face][0]:
                        best[face] = (float(d[0]), l)
            if not best:
                break
            for face, (_, l) in best.items():
                labels[face] = l
            left -= set(best)


def _same_surface(feature, found, points, layer):
    """Whether the layer's `feature` has the surface of the region's feature `found` where it lies,
    of the same type: the region feature's surface under its `points` (their nearest points on it)
    within the layer's distance tolerance of the feature's surface; for planes, as the idealization
    would make them one (coplanar): normals within the layer's angle tolerance and the found plane's
    centre within the distance tolerance of the feature's plane (a sculpted face tilts its refitted
    pieces by a fraction of a degree, which over their length exceeds the distance tolerance)."""
    if feature["type"] != found["type"] or feature["type"] == "freeform" or len(points) == 0:
        return False
    on_found, _ = native.onto_surface(found["type"], found["params"], np.ascontiguousarray(points, float))
    if feature["type"] == "plane":
        normal = np.asarray(feature["params"]["normal"], float)
        turn = np.degrees(np.arccos(min(1.0, abs(float(normal @ np.asarray(found["params"]["normal"], float))))))
        offset = abs(float((on_found.mean(axis=0) - np.asarray(feature["params"]["point"], float)) @ normal))
        return turn <= (layer.angle_tolerance or 10.0) and offset <= layer.distance_tolerance
    _, distance = native.onto_surface(feature["type"], feature["params"], on_found)
    return float(distance.max()) <= layer.distance_tolerance


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
    near = _grow(F, changed, 1)  # the changed faces and their ring: what the steps below look at
    neighbours = _region_neighbours(F, near)
    rest = changed & ~_absorb_into_kept(layer, V, F, labels, changed, neighbours)
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
        region_mesh = Mesh(V[used], index[F[region]])
        # Segmented as densely as the whole part would be (a small region alone would be refined to
        # a whole part's minimum sampling): its share of the part's surface.
        part_area = sum(f.get("area", 0.0) for f in layer.features)
        share = min(1.0, float(region_mesh.triangle_areas().sum()) / part_area) if part_area > 0 else 1.0
        sub = idealize(region_mesh, segment(region_mesh, part_share=max(share, 1e-9)),
                       distance_tolerance=layer.distance_tolerance,
                       angle_tolerance=layer.angle_tolerance or 10.0, measured=True)
        sub_labels = np.asarray(sub.labels)
        region_faces = np.flatnonzero(region)
        around = set(labels[region & ~rest].tolist()) - {-1}
        mapping = {}
        for s in sub.features:
            mine = sub_labels == s["id"]
            points = sub.mesh.vertices[np.unique(sub.mesh.faces[mine])]
            match = [f for f in sorted(around) if _same_surface(layer.features[f], s, points, layer)]
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
    relations = _join_parallel(relations, _snap_directions(layer, features, count))
    _refit_inside(V, F, labels, features, count, near)
    relations += _semi_defined(layer, V, F, labels, features, count, neighbours)
    _dissolve_folded(V, F, labels, features, count, neighbours)
    return _assemble(layer, mesh, labels, changed, features, relations, adjacency_before, sub_adjacency, near)


def _assemble(layer, mesh, labels, changed, features, relations, adjacency_before, sub_adjacency, near):
    V, F = mesh.vertices, mesh.faces
    labels = labels.astype(np.int32)
    tables = native.feature_tables(V, F, labels, len(features))
    pairs = tables["vertex_features"]  # (vertex, feature), by feature
    on_features = np.bincount(pairs[:, 0], minlength=len(V))
    # Vertices of changed faces on one feature only go onto its surface; those that unchanged faces
    # share stay, and so do those on several features' borders. The unchanged faces that share a
    # vertex with a changed one are in `near`, the changed faces' ring.
    movable = np.zeros(len(V), dtype=bool)
    movable[F[changed].ravel()] = True
    movable[F[near & ~changed].ravel()] = False
    movable &= on_features == 1
    idealized = V.copy()
    deviation = np.full(len(V), np.nan)
    bounds = np.searchsorted(pairs[:, 1], np.arange(len(features) + 1))
    for f in features:
        vertices = pairs[bounds[f["id"]]:bounds[f["id"] + 1], 0]
        if len(vertices) == 0 or f["type"] == "freeform":
            continue
        closest, distance = native.onto_surface(f["type"], f["params"], np.ascontiguousarray(V[vertices], float))
        deviation[vertices] = np.fmax(deviation[vertices], distance)
        move = movable[vertices]
        idealized[vertices[move]] = closest[move]
        deviation[vertices[move]] = 0.0
    # The graph from the faces now: the layer's edges where they remain, the region's new ones.
    adjacency = [adjacency_before.get(p) or dict(sub_adjacency.get(p, {"continuity": "G0", "angle": 0.0, "length": 0.0}),
                                                  a=p[0], b=p[1]) for p in map(tuple, tables["adjacent"].tolist())]
    present = {f["id"] for f in features}
    unique, seen = [], set()  # the region's relations may repeat one (two of its features became one)
    for r in relations:
        key = (r["kind"], tuple(r["features"]))
        if key not in seen and all(m in present for m in r["features"]):
            seen.add(key)
            unique.append(r)
    relations = unique
    for f in features:
        f["area"], f["triangles"] = float(tables["area"][f["id"]]), int(tables["triangles"][f["id"]])
    finite = deviation[np.isfinite(deviation)]
    result = {
        "labels": labels, "features": features, "adjacency": adjacency, "relations": relations,
        "idealized_vertices": idealized, "vertex_deviation": deviation,
        "max_deviation": float(finite.max()) if finite.size else 0.0,
        "rms_deviation": float(np.sqrt(np.mean(finite ** 2))) if finite.size else 0.0,
        "distance_tolerance": layer.distance_tolerance, "form_deviation": layer.form_deviation,
        "mesh_kind": layer.mesh_kind, "angle_tolerance_degrees": layer.angle_tolerance,
        "noise": layer.noise, "normal_noise": layer.normal_noise, "timings": []}
    out = FeatureLayer(Mesh(V, F, source=getattr(mesh, "source", None)), None, result)
    out.changed_faces = changed
    return out
