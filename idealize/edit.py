"""Feature-based editing of a feature layer (thesis 6.1): push/pull a face, change a parameter,
move or rotate features. The edit propagates through the feature graph (tangent fillets roll along
the faces they join, related features follow the relations kept), the mesh's vertices move onto
the new surfaces, and adaptive remeshing keeps its triangles well shaped.

Each function returns a new :class:`idealize.FeatureLayer`; the input layer is never modified. An
edit that no ideal configuration satisfies raises :class:`EditConflict`, naming the features.
"""
import time

import numpy as np

from ._loader import native
from .features import FeatureLayer, as_feature_layer
from .mesh import Mesh

#: Raised when no ideal configuration satisfies an edit (a fillet larger than its wall, a face
#: pushed through the one behind it); the message names the features in conflict.
EditConflict = native.EditConflict

#: The relations an edit can keep; all are kept unless `keep` says otherwise.
RELATIONS = ("tangent", "coplanar", "coaxial", "concentric", "equal_radius")

# The parameters set_parameter changes, per surface type: the report's name -> the core's.
_PARAMETERS = {
    "cylinder": {"radius": "radius"},
    "sphere": {"radius": "radius"},
    "torus": {"major": "radius", "minor": "minor_radius"},
    "cone": {"half_angle": "half_angle"},
}


def push_pull(layer, feature_id, distance, keep=None, remesh=True):
    """Moves a face along its normal by `distance`: a plane is offset, a round surface's radius
    (a torus's tube) grows or shrinks. A positive distance moves the face outward, away from the
    material, so pulling a solid's plane adds material."""
    return _edit(layer, [feature_id], parameter="offset", value=float(distance), keep=keep, remesh=remesh)


def set_parameter(layer, feature_id, name, value, keep=None, remesh=True):
    """Sets a parameter of a feature: ``radius`` of a cylinder or sphere, ``major`` or ``minor`` of a
    torus, ``half_angle`` (radians) of a cone, or ``offset`` (as :func:`push_pull`) of any."""
    layer = as_feature_layer(layer)
    feature = _feature(layer, feature_id)
    if name == "offset":
        return push_pull(layer, feature_id, value, keep=keep, remesh=remesh)
    names = _PARAMETERS.get(feature["type"], {})
    if name not in names:
        raise ValueError("a %s has no parameter %r; it has %s" % (
            feature["type"], name, ", ".join(["offset"] + sorted(names))))
    return _edit(layer, [feature_id], parameter=names[name], value=float(value), keep=keep, remesh=remesh)


def move(layer, feature_ids, translation, rotation=None, onto=None, keep=None, remesh=True):
    """Moves features rigidly by `translation` (3 numbers): a hole across its face, a cone along
    its axis.

    A feature group that sits as an island on planes (:func:`feature_group`: a boss, a pocket, a
    counterbored hole) travels as a decal: it is lifted off, its place closed, and placed again as
    :func:`copy` places a copy (turned by `rotation` degrees about the host's normal first), so it
    may go anywhere on its host, overlapping its old place or not, or onto another plane (`onto`);
    its features keep their ids. Other features move by deforming the mesh
    around them, their tangent neighbours following unless `keep` says otherwise; `rotation` is
    for groups only (see :func:`rotate` for the rest)."""
    layer = as_feature_layer(layer)
    ids = _ids(feature_ids)
    if _island(layer, ids):
        return _carried(layer, ids, translation, rotation, onto, remesh)
    if rotation is not None or onto is not None:
        raise ValueError("features %s are not a group sitting on planes: they move only along their own faces, "
                         "with no turn and onto no other face" % ids)
    return _deformed(layer, ids, translation, keep, remesh)


def _deformed(layer, ids, translation, keep, remesh):
    """Features `ids` moved by `translation`, the mesh around them stretched and remeshed."""
    motion = np.eye(4)
    motion[:3, 3] = _vector(translation, "translation")
    return _edit(layer, ids, motion=motion, keep=keep, remesh=remesh)


def rotate(layer, feature_ids, degrees, axis=None, center=None, keep=None, remesh=True):
    """Rotates features by `degrees` about the line through `center` along `axis`; by default the
    first feature's own axis (its normal for a plane, through its point)."""
    layer = as_feature_layer(layer)
    ids = _ids(feature_ids)
    params = _feature(layer, ids[0])["params"]
    if axis is None:
        axis = params.get("axis", params.get("normal"))
        if axis is None:
            raise ValueError("feature %d has no axis of its own: give one" % ids[0])
    if center is None:
        center = params.get("point", params.get("center", params.get("apex")))
    axis = _vector(axis, "axis")
    if not np.linalg.norm(axis) > 0:
        raise ValueError("the axis of rotation has no direction")
    axis = axis / np.linalg.norm(axis)
    center = _vector(center, "center")
    angle = np.radians(float(degrees))
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rotation = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k  # Rodrigues
    motion = np.eye(4)
    motion[:3, :3] = rotation
    motion[:3, 3] = center - rotation @ center
    return _edit(layer, ids, motion=motion, keep=keep, remesh=remesh)


def feature_group(layer, feature_id):
    """The feature group that feature `feature_id` belongs to: a boss with its walls, top and the
    blends at its base, a hole with its chamfers, a pocket with its walls and floor, a notch in an
    edge. The group ends at its hosts: the planes and cylinders around which it is an island
    (thesis 6.2), or whose edge it dents (a notch, a boss against a wall or over an edge). A
    feature of the part's outline has no group of its own: the group is the feature alone.

    Returns ``{"members": [ids], "hosts": [ids]}``, sorted; the user may add or drop members before
    passing them to :func:`delete`."""
    return {key: value for key, value in _group(layer, feature_id).items() if key != "island"}


def _group(layer, feature_id):
    """feature_group's dict, with "island": whether each border loop of the group runs along one
    host (only such a group travels as a decal)."""
    layer = as_feature_layer(layer)
    _feature(layer, feature_id)
    group = native.feature_group(*_layer_arguments(layer)[:5], int(feature_id),
                                 distance_tolerance=float(layer.distance_tolerance))
    return {"members": list(group["members"]), "hosts": list(group["hosts"]), "island": bool(group["island"])}


def copy(layer, feature_ids, translation, rotation=None, onto=None, remesh=True):
    """Copies a feature group (see :func:`feature_group`) to another place on the planes it sits on,
    as a decal: its triangles and surfaces are carried rigidly, the host opens a gap of the group's
    outline there and the ring around it is triangulated and remeshed. `translation` (3 numbers)
    must lie along the host planes; `rotation` (degrees) turns the copy counter-clockwise about
    the host's outward normal through the group's centre first (a group on a cylinder: about the
    cylinder's axis, and the translation along it). With `onto` (a plane feature's id),
    the copy goes onto that face instead: its centre to the nearest point of that plane, facing out
    of it, then turned and moved along it. The original stays; the copies get
    new ids after the layer's (``layer.copies``: per id given, its copy's id; ``layer.created`` flags
    the ring's triangles).

    A new place off the host, reaching its edge or another feature, or overlapping the group
    raises :class:`EditConflict` naming them; so does a copy that would cut through the part (its
    triangles crossing others), and the layer is left as it was."""
    layer = as_feature_layer(layer)
    ids = _ids(feature_ids)
    for f in ids:
        _feature(layer, f)
    start = time.perf_counter()
    result = _placed(native.copy_features, layer, ids, translation, rotation, onto, remesh)
    copies = list(result["copies"])
    result["changed"] = [False] * len(result["params"])
    out = _edited_layer(layer, result, _keep_flags(None), time.perf_counter() - start,
                        _copied_graph(layer, ids, copies))
    _refuse_crossings(out, "the copy")
    out.changed = sorted(set(result["hosts"]) | set(copies))
    out.copies = copies
    out.created = np.asarray(result["created"], dtype=bool)
    return out


def delete(layer, feature_ids, remesh=True):
    """Deletes features, usually a group of :func:`feature_group`: their triangles are lifted off and
    the faces around each gap erode into it until it is closed, then remeshed. A group inside one
    plane or cylinder is closed on it; a group that sat across edges (a notch in an edge, a boss
    against a wall, a rib between two walls) is closed by its neighbours meeting along new edges,
    and identical faces it kept apart join into one (the false edge between them is not made).

    The other features keep their surfaces exactly; they are renumbered in order
    (``layer.renumbered`` maps each old id that remains to its new one, a joined face to the one
    it joined; ``layer.merged`` lists those (old id, old id joined); ``layer.created`` flags the
    triangles that close the gaps; ``layer.new_edges`` and ``layer.corners`` count what the
    erosion made). A gap the faces around it cannot close raises :class:`EditConflict` naming
    them."""
    layer = as_feature_layer(layer)
    ids = _ids(feature_ids)
    for f in ids:
        _feature(layer, f)
    start = time.perf_counter()
    result = native.delete_features(*_layer_arguments(layer), ids, **_structure_options(layer, remesh))
    kept = list(result["kept"])
    renumbered = {old: new for new, old in enumerate(kept)}
    result["params"] = [layer.features[old]["params"] for old in kept]
    result["changed"] = [False] * len(kept)
    features, adjacency, relations = _renumbered_graph(layer, renumbered)
    merged = [(int(old), int(into)) for old, into in result["merged"]]
    joined = dict(renumbered)
    joined.update({old: renumbered[into] for old, into in merged})
    # A joined face's edges pass to the face it joined, and the new edges join the graph.
    pairs = {(a["a"], a["b"]) for a in adjacency} | {(a["b"], a["a"]) for a in adjacency}
    extra = [(joined[a["a"]], joined[a["b"]], a) for a in layer.adjacency
             if a["a"] in joined and a["b"] in joined and (a["a"] not in renumbered or a["b"] not in renumbered)]
    extra += [(a, b, {"continuity": "G0"}) for a, b in result["edges"]]
    for a, b, edge in extra:
        if a != b and (a, b) not in pairs:
            adjacency.append(dict(edge, a=a, b=b))
            pairs |= {(a, b), (b, a)}
    out = _edited_layer(layer, result, _keep_flags(None), time.perf_counter() - start,
                        (features, adjacency, relations))
    out.changed = list(result["hosts"])
    out.renumbered = joined
    out.merged = merged
    out.new_edges = int(result["new_edges"])
    out.corners = int(result["corners"])
    out.created = np.asarray(result["created"], dtype=bool)
    return out


def set_depth(layer, hole_feature_id, depth, entry=None, remesh=True):
    """Gives a plain hole (its wall, a cylinder, and a flat floor or none) the depth `depth`,
    measured along its axis from the face it is drilled from (`entry`, a feature id; by default a
    blind hole's face, or the larger of a through hole's two). A depth that reaches the far side
    (within the distance tolerance) makes a through hole: the far face opens. A through hole given a
    smaller depth becomes blind again, with a flat floor.

    The hole is remade: its wall and floor get new ids after the other features, which keep their
    surfaces exactly and are renumbered in order (``layer.renumbered``; ``layer.hole`` is
    ``{"wall": id, "floor": id or None, "through": bool, "depth": mm}``). A hole with chamfers or a
    counterbore, or one whose axis leaves the part through a face that is not a plane, raises
    :class:`EditConflict` naming the features."""
    layer = as_feature_layer(layer)
    wall = int(hole_feature_id)
    _feature(layer, wall)
    if entry is not None:
        _feature(layer, entry)
    start = time.perf_counter()
    result = native.set_hole_depth(*_layer_arguments(layer), wall, float(depth),
                                   entry=-1 if entry is None else int(entry), **_structure_options(layer, remesh))
    kept = [old for old in result["kept"] if old >= 0]
    renumbered = {old: new for new, old in enumerate(kept)}
    features, adjacency, relations = _renumbered_graph(layer, renumbered)
    new_wall, new_floor = result["wall"], result["floor"]
    hosts = list(result["hosts"])
    wall_feature = dict(layer.features[wall], id=new_wall)
    features.append(wall_feature)
    adjacency += [{"a": h, "b": new_wall, "continuity": "G0"} for h in hosts]
    if new_floor >= 0:
        features.append(dict(features[hosts[0]], id=new_floor))
        adjacency.append({"a": new_wall, "b": new_floor, "continuity": "G0"})
    result["changed"] = [False] * len(features)
    out = _edited_layer(layer, result, _keep_flags(None), time.perf_counter() - start,
                        (features, adjacency, relations))
    out.changed = sorted(set(hosts) | {new_wall} | ({new_floor} if new_floor >= 0 else set()))
    out.renumbered = renumbered
    out.created = np.asarray(result["created"], dtype=bool)
    out.hole = {"wall": new_wall, "floor": new_floor if new_floor >= 0 else None,
                "through": bool(result["through"]), "depth": float(result["depth"])}
    return out


def _island(layer, ids):
    """Whether features `ids` are a whole feature group on host planes or cylinders."""
    for f in ids:
        _feature(layer, f)
    group = _group(layer, ids[0])
    return (sorted(set(ids)) == group["members"] and bool(group["hosts"]) and group["island"]
            and all(layer.features[h]["type"] in ("plane", "cylinder") for h in group["hosts"]))


def _carried(layer, ids, translation, rotation, onto, remesh):
    """The group `ids` lifted off and placed again at its new place (native.move_features)."""
    start = time.perf_counter()
    result = _placed(native.move_features, layer, ids, translation, rotation, onto, remesh)
    result["changed"] = [f in ids for f in range(len(layer.features))]
    out = _edited_layer(layer, result, _keep_flags(None), time.perf_counter() - start)
    _refuse_crossings(out, "the moved group")
    out.changed = sorted(set(result["hosts"]) | set(ids))
    out.created = np.asarray(result["created"], dtype=bool)
    return out


def _placed(function, layer, ids, translation, rotation, onto, remesh):
    """native.copy_features or move_features of the group `ids` of `layer`."""
    if onto is not None:
        _feature(layer, onto)
    return function(*_layer_arguments(layer), ids, _vector(translation, "translation"),
                    np.radians(float(rotation or 0.0)), onto=-1 if onto is None else int(onto),
                    **_structure_options(layer, remesh))


def _layer_arguments(layer):
    """What the core's structure-altering edits read of a layer: V, F, labels, types, params,
    adjacency."""
    faces, labels = _kept_triangles(layer)
    return (np.ascontiguousarray(layer.idealized_vertices, dtype=np.float64), faces, labels,
            [f["type"] for f in layer.features], [dict(f["params"]) for f in layer.features], list(layer.adjacency))


def _structure_options(layer, remesh):
    return {"distance_tolerance": float(layer.distance_tolerance), "remesh": bool(remesh),
            "target_edge_lengths": list(layer.edge_lengths or [])}


# The edits `apply` replays: {"op": name, ...the function's keyword arguments}.
_OPERATIONS = {"push_pull": ("feature_id", "distance"), "set_parameter": ("feature_id", "name", "value"),
               "move": ("feature_ids", "translation", "rotation", "onto"),
               "rotate": ("feature_ids", "degrees", "axis", "center"),
               "delete": ("feature_ids",), "copy": ("feature_ids", "translation", "rotation", "onto"),
               "set_depth": ("hole_feature_id", "depth", "entry"), "sculpt": ("strokes",)}


def apply(layer, edits):
    """Applies a list of edits in order and returns the last layer: each edit is a dict
    ``{"op": "push_pull" | "set_parameter" | "move" | "rotate" | "delete" | "copy" | "set_depth" | "sculpt",
    ...}`` with the keyword arguments of the function of that name (and ``keep``, ``remesh``;
    sculpt: :func:`idealize.sculpt.sculpt`), as a document stores its edit history, e.g.
    ``{"op": "push_pull", "feature_id": 3, "distance": 5.0}``."""
    from .sculpt import sculpt
    functions = {"push_pull": push_pull, "set_parameter": set_parameter, "move": move, "rotate": rotate,
                 "delete": delete, "copy": copy, "set_depth": set_depth, "sculpt": sculpt}
    for number, step in enumerate(edits):
        step = dict(step)
        op = step.pop("op", None)
        if op not in functions:
            raise ValueError("edit %d: unknown operation %r; the operations are %s" % (
                number + 1, op, ", ".join(sorted(functions))))
        allowed = set(_OPERATIONS[op]) | (set() if op == "sculpt" else {"remesh"} if op in ("delete", "copy", "set_depth")
                                          else {"keep", "remesh"})
        unknown = set(step) - allowed
        if unknown:
            raise ValueError("edit %d (%s): unknown argument(s) %s" % (number + 1, op, sorted(unknown)))
        layer = functions[op](layer, **step)
    return as_feature_layer(layer)


def _vector(value, name):
    v = np.asarray(value, dtype=np.float64).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError("the %s must be 3 finite numbers, got %r" % (name, value))
    return v


def _ids(feature_ids):
    ids = [int(feature_ids)] if np.isscalar(feature_ids) else [int(f) for f in feature_ids]
    if not ids:
        raise ValueError("no feature to edit")
    return ids


def _feature(layer, feature_id):
    if not 0 <= int(feature_id) < len(layer.features):
        raise ValueError("the layer has no feature %r (it has %d)" % (feature_id, len(layer.features)))
    return layer.features[int(feature_id)]


def _keep_flags(keep):
    """{relation: bool} from None (keep all), a dict of flags, or the names of the relations kept."""
    if keep is None:
        return {name: True for name in RELATIONS}
    if isinstance(keep, dict):
        unknown = set(keep) - set(RELATIONS)
        flags = {name: bool(keep.get(name, True)) for name in RELATIONS}
    else:
        kept = set(keep)
        unknown = kept - set(RELATIONS)
        flags = {name: name in kept for name in RELATIONS}
    if unknown:
        raise ValueError("unknown relation(s) %s; the relations are %s" % (sorted(unknown), ", ".join(RELATIONS)))
    return flags


def _edit(layer, feature_ids, motion=None, parameter="none", value=0.0, keep=None, remesh=True):
    layer = as_feature_layer(layer)
    for f in feature_ids:
        _feature(layer, f)
    flags = _keep_flags(keep)
    start = time.perf_counter()
    faces, labels = _kept_triangles(layer)
    result = native.edit_features(
        np.ascontiguousarray(layer.idealized_vertices, dtype=np.float64), faces, labels,
        [f["type"] for f in layer.features], [dict(f["params"]) for f in layer.features],
        list(layer.adjacency), [dict(r) for r in layer.relations], feature_ids,
        motion=np.eye(4) if motion is None else motion, parameter=parameter, value=value, keep=flags,
        distance_tolerance=float(layer.distance_tolerance), remesh=bool(remesh),
        target_edge_lengths=list(layer.edge_lengths or []))
    return _edited_layer(layer, result, flags, time.perf_counter() - start)


def _kept_triangles(layer):
    """The layer's triangles (oriented) and labels without those the mesh check sets aside: a
    triangle that repeats a vertex, or repeats another triangle (the edited mesh is one manifold
    surface, which they would break)."""
    faces = np.asarray(layer.oriented_faces, dtype=np.int32)
    labels = np.asarray(layer.labels, dtype=np.int32)
    ordered = np.sort(faces, axis=1)
    distinct = (ordered[:, 0] != ordered[:, 1]) & (ordered[:, 1] != ordered[:, 2])
    _, first = np.unique(ordered, axis=0, return_index=True)
    keep = np.zeros(len(faces), dtype=bool)
    keep[first] = True
    keep &= distinct
    return np.ascontiguousarray(faces[keep]), np.ascontiguousarray(labels[keep])


def _renumbered_graph(layer, renumbered):
    """The layer's features, adjacency and relations with the features of `renumbered` (old id ->
    new id) only, under their new ids: a relation keeps the members that remain, if two do."""
    features = []
    for old, new in sorted(renumbered.items(), key=lambda item: item[1]):
        f = dict(layer.features[old])
        f["id"] = new
        features.append(f)
    adjacency = []
    for a in layer.adjacency:
        if a["a"] in renumbered and a["b"] in renumbered:
            a = dict(a)
            a["a"], a["b"] = renumbered[a["a"]], renumbered[a["b"]]
            adjacency.append(a)
    relations = []
    for r in layer.relations:
        members = [renumbered[m] for m in r["features"] if m in renumbered]
        if len(members) >= 2:  # the surfaces did not change: what held among them holds
            r = dict(r)
            r["features"] = members
            relations.append(r)
    return features, adjacency, relations


def _copied_graph(layer, ids, copies):
    """The layer's features, adjacency and relations, then the copies of features `ids` (new ids
    `copies`): each copy borders and relates to what its original does, copies standing for the
    originals among the copied."""
    copy_of = dict(zip(ids, copies))
    features = list(layer.features)
    for old, new in sorted(copy_of.items(), key=lambda item: item[1]):
        f = dict(layer.features[old])
        f["id"] = new
        features.append(f)
    adjacency = list(layer.adjacency)
    for a in layer.adjacency:
        if a["a"] in copy_of or a["b"] in copy_of:
            a = dict(a)
            a["a"], a["b"] = copy_of.get(a["a"], a["a"]), copy_of.get(a["b"], a["b"])
            adjacency.append(a)
    relations = list(layer.relations)
    for r in layer.relations:
        if any(m in copy_of for m in r["features"]):
            r = dict(r)
            r["features"] = [copy_of.get(m, m) for m in r["features"]]
            relations.append(r)
    return features, adjacency, relations


def _refuse_crossings(layer, what):
    """Raises EditConflict when the edited mesh's triangles cross: the edit cut through the part."""
    crossing = native.self_intersections(np.ascontiguousarray(layer.idealized_vertices, dtype=np.float64),
                                         np.ascontiguousarray(layer.mesh.faces, dtype=np.int32))
    if crossing:
        raise EditConflict("%s would cut through the part (%d pairs of its triangles cross): place it where it "
                           "does not reach another face" % (what, crossing))


def _edited_layer(layer, result, flags, seconds, graph=None):
    V, F, labels = result["V"], result["F"], result["labels"]
    if graph is None:
        features_before, adjacency, relations_before = layer.features, list(layer.adjacency), layer.relations
    else:
        features_before, adjacency, relations_before = graph
    changed = result["changed"]
    deviation = result["vertex_deviation"]
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    areas = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    count = len(features_before)
    area = np.bincount(labels, weights=areas, minlength=count)
    triangles = np.bincount(labels, minlength=count)
    # Each feature's residual: its vertices' distances (the nearest of their features').
    corners = np.nan_to_num(deviation[F], nan=0.0)
    squared = np.bincount(labels, weights=(corners ** 2).sum(axis=1), minlength=count)
    worst = np.zeros(count)
    np.maximum.at(worst, labels, corners.max(axis=1))
    features = []
    for f, params in zip(features_before, result["params"]):
        g = dict(f)
        if f["type"] != "freeform":
            g["params"] = params
            g["best_fit"] = (f["type"], params)
            g["rms"] = float(np.sqrt(squared[f["id"]] / max(3 * triangles[f["id"]], 1)))
            g["max_error"] = float(worst[f["id"]])
        g["area"] = float(area[f["id"]])
        g["triangles"] = int(triangles[f["id"]])
        features.append(g)
    # A relation kind the edit did not keep holds no more for the groups it changed.
    relations = [r for r in relations_before
                 if flags.get(r["kind"], True) or not any(changed[m] for m in r["features"])]
    finite = deviation[np.isfinite(deviation)]
    edited = {
        "labels": labels, "features": features, "adjacency": adjacency, "relations": relations,
        "idealized_vertices": V, "vertex_deviation": deviation,
        "max_deviation": float(finite.max()) if finite.size else 0.0,
        "rms_deviation": float(np.sqrt(np.mean(finite ** 2))) if finite.size else 0.0,
        "distance_tolerance": layer.distance_tolerance, "form_deviation": 0.0,
        # The edited mesh lies on its features, as a CAD export's does.
        "mesh_kind": "exact tessellation", "angle_tolerance_degrees": layer.angle_tolerance,
        "noise": 0.0, "normal_noise": 0.0, "timings": [("edit", seconds)],
    }
    out = FeatureLayer(Mesh(V, F, source=layer.mesh.source), None, edited)
    out.changed = [i for i, flag in enumerate(changed) if flag]
    # The density of the first edit's mesh, which successive edits keep (no drift).
    out.edge_lengths = list(result["target_edge_lengths"])
    # Why the adaptive remeshing did not run (None when it did): the vertices moved, the
    # triangles stretched as they came.
    out.remeshing_problem = result["remeshing_problem"] or None
    return out
