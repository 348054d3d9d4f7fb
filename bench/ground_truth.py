"""Ground truth of the feature benchmark, read from the STEP B-rep: every face's surface type and
exact parameters, which faces share an edge and whether they meet tangentially, and the relations
between faces defined as the library defines them (see native/src/features/feature_graph.h).
"""

from __future__ import annotations

import itertools
import math
from typing import Dict, List, Set, Tuple

import numpy as np

import datasets

TYPE_NAMES = {"Plane": "plane", "Cylinder": "cylinder", "Cone": "cone", "Sphere": "sphere", "Toroid": "torus"}
TANGENT_DEGREES = 1.0      # B-rep blends meet exactly tangentially; sharp edges of real parts are far steeper
EXACT_DEGREES = 0.01       # relations in the ground truth hold exactly
EXACT_DISTANCE = 1e-5      # x diagonal

Pair = Tuple[int, int]


def _vec(v) -> List[float]:
    return [float(v.x), float(v.y), float(v.z)]


def face_surface(face) -> Dict:
    """{"type", "params"} of a B-rep face, with the library's parameter names."""
    s = face.Surface
    kind = TYPE_NAMES.get(type(s).__name__, "freeform")
    if kind == "plane":
        params = {"normal": _vec(s.Axis), "point": _vec(s.Position)}
    elif kind == "cylinder":
        params = {"axis": _vec(s.Axis), "point": _vec(s.Center), "radius": float(s.Radius)}
    elif kind == "cone":
        params = {"axis": _vec(s.Axis), "apex": _vec(s.Apex), "half_angle": float(s.SemiAngle)}
    elif kind == "sphere":
        params = {"center": _vec(s.Center), "radius": float(s.Radius)}
    elif kind == "torus":
        params = {"axis": _vec(s.Axis), "center": _vec(s.Center), "major": float(s.MajorRadius),
                  "minor": float(s.MinorRadius)}
    else:
        params = {}
    return {"type": kind, "params": params}


def _normal_at(face, point):
    u, v = face.Surface.parameter(point)
    return np.array(_vec(face.normalAt(u, v)))


def face_adjacency(solid) -> List[Dict]:
    """Pairs of faces sharing an edge, with the angle between their normals at the edge middle."""
    faces = solid.Faces
    index = {}
    for i, f in enumerate(faces):
        index.setdefault(f.hashCode(), []).append(i)
    seen: Dict[Pair, float] = {}
    Part = datasets.freecad_modules()[1]
    for edge in solid.Edges:
        owners = []
        for f in solid.ancestorsOfType(edge, Part.Face):
            owners += [i for i in index.get(f.hashCode(), []) if faces[i].isSame(f) and i not in owners]
        if len(owners) != 2 or edge.Length <= 0:
            continue
        a, b = sorted(owners)
        middle = edge.valueAt(0.5 * (edge.FirstParameter + edge.LastParameter))
        try:
            na, nb = _normal_at(faces[a], middle), _normal_at(faces[b], middle)
            angle = math.degrees(math.acos(max(-1.0, min(1.0, float(np.dot(na, nb))))))
        except Exception:  # a degenerate edge where a normal is undefined
            continue
        seen[(a, b)] = max(seen.get((a, b), 0.0), angle)
    return [{"a": a, "b": b, "angle_degrees": angle} for (a, b), angle in sorted(seen.items())]


def part_ground_truth(part_path) -> Dict:
    """Faces and adjacency of a STEP part, cached next to the benchmark meshes."""
    part = datasets._Part(part_path)
    path = datasets._cache_path("features", part.stem, {"file": part.digest})
    hit = datasets._load(path)
    if hit is not None:
        return hit[1]
    solid = part.solid()
    gt = {"faces": [face_surface(f) for f in solid.Faces], "adjacency": face_adjacency(solid),
          "diag": float(solid.BoundBox.DiagonalLength)}
    datasets._save(path, {}, gt)
    return gt


def _direction(surface: Dict):
    p = surface["params"]
    if surface["type"] == "plane":
        return np.array(p["normal"])
    if surface["type"] in ("cylinder", "cone", "torus"):
        return np.array(p["axis"])
    return None


def _anchor(surface: Dict):
    p = surface["params"]
    return np.array(p.get("point") or p.get("apex") or p.get("center"))


def _tube_radius(surface: Dict):
    p = surface["params"]
    return p.get("minor", p.get("radius")) if surface["type"] in ("cylinder", "sphere", "torus") else None


def relations(surfaces: Dict[int, Dict], adjacency: List[Tuple[int, int, bool]], angle_degrees: float,
              distance: float) -> Dict[str, Set[Pair]]:
    """Relation pairs among `surfaces` (id -> {"type", "params"}) by the library's definitions.

    adjacency: (a, b, tangent) for faces that share an edge.
    """
    cos_tol, sin_tol = math.cos(math.radians(angle_degrees)), math.sin(math.radians(angle_degrees))
    out: Dict[str, Set[Pair]] = {k: set() for k in ("parallel", "perpendicular", "coplanar", "coaxial",
                                                     "equal_radius", "concentric", "tangent")}
    ids = sorted(i for i, s in surfaces.items() if s["type"] != "freeform")
    for a, b in itertools.combinations(ids, 2):
        sa, sb = surfaces[a], surfaces[b]
        da, db = _direction(sa), _direction(sb)
        if da is not None and db is not None and abs(float(np.dot(da, db))) >= cos_tol:
            out["parallel"].add((a, b))
            offset = _anchor(sb) - _anchor(sa)
            if sa["type"] == sb["type"] == "plane" and abs(float(np.dot(offset, da))) <= distance:
                out["coplanar"].add((a, b))
            axial = ("cylinder", "cone", "torus")
            if sa["type"] in axial and sb["type"] in axial and \
                    np.linalg.norm(offset - np.dot(offset, da) * da) <= distance:
                out["coaxial"].add((a, b))
        ra, rb = _tube_radius(sa), _tube_radius(sb)
        if ra is not None and rb is not None and abs(ra - rb) <= distance:
            out["equal_radius"].add((a, b))
        if sa["type"] in ("sphere", "torus") and sb["type"] in ("sphere", "torus") and \
                np.linalg.norm(_anchor(sa) - _anchor(sb)) <= distance:
            out["concentric"].add((a, b))
    for a, b, tangent in adjacency:
        a, b = min(a, b), max(a, b)
        if a not in surfaces or b not in surfaces:
            continue
        if tangent:
            out["tangent"].add((a, b))
        da, db = _direction(surfaces[a]), _direction(surfaces[b])
        if surfaces[a]["type"] != "freeform" and surfaces[b]["type"] != "freeform" and \
                da is not None and db is not None and abs(float(np.dot(da, db))) <= sin_tol:
            out["perpendicular"].add((a, b))
    return out


def relation_pairs(relation_list: List[Dict]) -> Dict[str, Set[Pair]]:
    """The library's relation groups expanded into pairs."""
    out: Dict[str, Set[Pair]] = {}
    for r in relation_list:
        members = sorted(r["features"])
        out.setdefault(r["kind"], set()).update(itertools.combinations(members, 2))
    return out


def same_surface(a: Dict, b: Dict, diag: float) -> bool:
    """Whether two faces lie on one surface (a STEP file often splits a periodic face in two)."""
    if a["type"] != b["type"] or a["type"] == "freeform":
        return False
    distance = EXACT_DISTANCE * diag
    pa, pb = a["params"], b["params"]
    for key in ("radius", "major", "minor"):
        if key in pa and abs(pa[key] - pb[key]) > distance:
            return False
    if "half_angle" in pa and abs(pa["half_angle"] - pb["half_angle"]) > math.radians(EXACT_DEGREES):
        return False
    if a["type"] == "sphere":
        return np.linalg.norm(np.subtract(pa["center"], pb["center"])) <= distance
    da, db = _direction(a), _direction(b)
    if abs(float(np.dot(da, db))) < math.cos(math.radians(EXACT_DEGREES)):
        return False
    offset = _anchor(b) - _anchor(a)
    if a["type"] == "plane":
        return abs(float(np.dot(offset, da))) <= distance
    if a["type"] == "cone":
        return np.linalg.norm(offset) <= distance  # same apex
    across = offset - np.dot(offset, da) * da
    return np.linalg.norm(across) <= distance and (a["type"] != "torus" or abs(float(np.dot(offset, da))) <= distance)


def surface_of_face(gt_info: Dict) -> np.ndarray:
    """For every B-rep face, the smallest index of the faces it is joined to through edges shared
    with faces on the same surface: one id per geometric surface patch."""
    faces = gt_info["faces"]
    parent = list(range(len(faces)))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for e in gt_info["adjacency"]:
        if same_surface(faces[e["a"]], faces[e["b"]], gt_info["diag"]):
            ra, rb = root(e["a"]), root(e["b"])
            parent[max(ra, rb)] = min(ra, rb)
    return np.array([root(i) for i in range(len(faces))], dtype=np.int64)
