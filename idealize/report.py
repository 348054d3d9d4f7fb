"""The JSON report of `python -m idealize convert`. Its key names are a public contract."""
import json
import math

import numpy as np

from . import __version__


def build_report(mesh, layer, timings, step, solid=None):
    """The report of one conversion; `layer` is the :class:`idealize.FeatureLayer`, `solid` the
    :class:`idealize.Solid` made from it (None: no "brep" entry)."""
    segmentation = layer.segmentation
    report = {
        "idealize_version": __version__,
        "input": {
            "path": mesh.source,
            "format": mesh.read_info.get("format"),
            "triangles": int(mesh.n_triangles),
            "vertices": int(mesh.n_vertices),
        },
        "repairs": {
            "degenerate_triangles_ignored": int(segmentation.removed_degenerate),
            "duplicate_triangles_merged": int(segmentation.removed_duplicate),
            "orientation_fixed": int(segmentation.mesh_check["flipped_faces_repaired"]),
        },
        "mesh_check": {key: _plain_check(value) for key, value in segmentation.mesh_check.items()},
        "labels": layer.labels,
        "transition_triangles": np.flatnonzero(segmentation.transition),
        "features": [_feature(f) for f in layer.features],
        "adjacency": [{"a": int(e["a"]), "b": int(e["b"]), "continuity": e["continuity"],
                       "angle": float(e["angle"]), "length": float(e["length"])} for e in layer.adjacency],
        "relations": [{"kind": r["kind"], "features": [int(i) for i in r["features"]]} for r in layer.relations],
        "deviation": {"max": float(layer.deviation["max"]), "rms": float(layer.deviation["rms"])},
        "form_deviation": float(layer.form_deviation),
        "mesh": {"kind": layer.mesh_kind, "noise": float(layer.noise), "normal_noise_degrees": math.degrees(layer.normal_noise)},
        "tolerances": {"distance": float(layer.distance_tolerance)},
        "timings": {name: round(float(seconds), 6) for name, seconds in timings.items()},
        "step": step,
    }
    if solid is not None:
        report["brep"] = solid.report()
    return report


def _feature(feature):
    out = {
        "id": int(feature["id"]),
        "type": feature["type"],
        "params": {key: _plain(value) for key, value in feature["params"].items()},
        "rms": float(feature["rms"]),
        "max_error": float(feature["max_error"]),
        "normal_rms": float(feature["normal_rms"]),
        "triangles": int(feature["triangles"]),
        "area": float(feature["area"]),
        "curvature_type": feature["curvature_type"],
        "curvature": {key: float(value) for key, value in feature["curvature"].items()},
    }
    if feature["type"] in ("cylinder", "sphere", "torus"):  # null where the points do not fix the radius
        error = float(feature["radius_error"])
        out["radius_error"] = error if np.isfinite(error) else None
    return out


def _plain_check(value):
    return bool(value) if isinstance(value, (bool, np.bool_)) else int(value)


def _plain(value):
    """Floats and lists of floats for JSON (axes, points) from numpy or tuples."""
    if isinstance(value, (tuple, list, np.ndarray)):
        return [float(v) for v in value]
    return float(value)


def write_report(report, path):
    """Pretty JSON, with the per-triangle arrays on one line each so that large meshes stay readable."""
    body = dict(report, labels="@labels@", transition_triangles="@transition_triangles@")
    text = json.dumps(body, indent=2)
    for key in ("labels", "transition_triangles"):
        text = text.replace('"@%s@"' % key, "[" + ",".join(map(str, np.asarray(report[key]).tolist())) + "]")
    with open(path, "w", encoding="utf-8") as handle:
        handle.write(text)
        handle.write("\n")
