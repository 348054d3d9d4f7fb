"""The JSON report of `python -m idealize convert`. Its key names are a public contract."""
import json

import numpy as np

from . import __version__


def build_report(mesh, segmentation, timings, step):
    return {
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
        },
        "labels": segmentation.labels,
        "transition_triangles": np.flatnonzero(segmentation.transition),
        "features": [_feature(f) for f in segmentation.features],
        "timings": {name: round(float(seconds), 6) for name, seconds in timings.items()},
        "step": step,
    }


def _feature(patch):
    low, high = patch["curvature_range"]
    return {
        "id": int(patch["id"]),
        "triangles": int(patch["triangles"]),
        "area": float(patch["area"]),
        "kind": patch["kind"],
        "mean_curvature": float(patch["mean_curvature"]),
        "curvature_range": [_finite_or_none(low), _finite_or_none(high)],
    }


def _finite_or_none(value):
    return float(value) if np.isfinite(value) else None


def write_report(report, path):
    """Pretty JSON, with the per-triangle arrays on one line each so that large meshes stay readable."""
    body = dict(report, labels="@labels@", transition_triangles="@transition_triangles@")
    text = json.dumps(body, indent=2)
    for key in ("labels", "transition_triangles"):
        text = text.replace('"@%s@"' % key, "[" + ",".join(map(str, np.asarray(report[key]).tolist())) + "]")
    with open(path, "w", encoding="utf-8") as handle:
        handle.write(text)
        handle.write("\n")
