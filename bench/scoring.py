"""Scoring a per-triangle segmentation against per-triangle ground-truth faces.

Overlaps are measured by triangle area, so the score does not depend on how finely a face is
tessellated. A ground-truth face is

* **correct** when one patch holds at least 80 % of the face's area *and* at least 80 % of that
  patch's area lies in the face (the thesis's "neither over- nor under-segmented");
* **over-segmented** when it is not correct because no patch holds 80 % of it: it was split
  into several patches, or largely eaten by transition triangles;
* **under-segmented** when the best patch does hold 80 % of it but less than 80 % of that patch
  lies in it: it was merged with other faces.

Every scored face is exactly one of the three. Ground-truth faces covering less than
``min_face_fraction`` of the total area (default 0.05 %) are not scored: on a 40k-triangle scan they
are a handful of triangles, smaller than a transition strip. Predicted label -1 means
transition/unassigned and is never a patch; ground-truth label -1 means "no face" and is never
scored (it still counts in patch areas, so merging into it costs the patch).
"""

from __future__ import annotations

from typing import Dict, List

import numpy as np

THRESHOLD = 0.8
MIN_FACE_FRACTION = 0.0005  # faces under this share of the surface are too small to score


def score(labels, gt, areas, min_face_fraction: float = MIN_FACE_FRACTION, threshold: float = THRESHOLD) -> Dict:
    """Scores predicted patch ids `labels` against ground-truth face ids `gt`, one per triangle,
    weighting triangles by `areas`.

    Returns a dict with the counts ``faces`` (scored), ``correct``, ``over``, ``under``,
    ``excluded_faces`` (too small to score), ``patches`` (distinct labels >= 0),
    ``significant_patches`` (patches of at least ``min_face_fraction`` of the area),
    ``gt_faces`` (distinct gt >= 0), ``correct_fraction``, ``transition_area_fraction``, and
    ``per_face``: one dict per scored face with ``face``, ``area_fraction``, ``best_patch``
    (-1 if only transitions cover it), ``face_fraction`` (share of the face in the best patch),
    ``patch_fraction`` (share of the best patch inside the face), ``patches_touching`` and
    ``status`` ("correct", "over", "under").
    """
    labels = np.asarray(labels).reshape(-1).astype(np.int64)
    gt = np.asarray(gt).reshape(-1).astype(np.int64)
    areas = np.asarray(areas, dtype=np.float64).reshape(-1)
    if not (len(labels) == len(gt) == len(areas)):
        raise ValueError(f"labels ({len(labels)}), gt ({len(gt)}) and areas ({len(areas)}) differ in length")
    if not np.all(np.isfinite(areas)) or np.any(areas < 0):
        raise ValueError("areas must be finite and non-negative")
    if not 0.0 < threshold <= 1.0:
        raise ValueError("threshold must be in (0, 1]")

    total = float(areas.sum())
    patch_ids = np.unique(labels[labels >= 0])
    face_ids = np.unique(gt[gt >= 0])
    result: Dict = {
        "faces": 0, "correct": 0, "over": 0, "under": 0, "excluded_faces": 0,
        "patches": int(len(patch_ids)), "significant_patches": 0, "gt_faces": int(len(face_ids)),
        "correct_fraction": 0.0,
        "transition_area_fraction": float(areas[labels < 0].sum() / total) if total > 0 else 0.0,
        "per_face": [],
    }
    if total <= 0 or len(face_ids) == 0:
        return result

    # Dense re-indexing of patches and faces, then one sparse overlap table.
    patch_index = np.searchsorted(patch_ids, labels)           # valid only where labels >= 0
    face_index = np.searchsorted(face_ids, gt)                 # valid only where gt >= 0
    patch_area = np.bincount(patch_index[labels >= 0], weights=areas[labels >= 0], minlength=len(patch_ids))
    face_area = np.bincount(face_index[gt >= 0], weights=areas[gt >= 0], minlength=len(face_ids))
    result["significant_patches"] = int(np.sum(patch_area >= min_face_fraction * total))

    both = (labels >= 0) & (gt >= 0)
    pair = face_index[both] * max(len(patch_ids), 1) + patch_index[both]
    pair_ids, inverse = np.unique(pair, return_inverse=True)
    pair_area = np.bincount(inverse, weights=areas[both], minlength=len(pair_ids))
    pair_face = pair_ids // max(len(patch_ids), 1)
    pair_patch = pair_ids % max(len(patch_ids), 1)

    # Best patch per face: largest overlap, ties to the smaller patch id (pairs are sorted by id).
    best_area = np.zeros(len(face_ids))
    best_patch = np.full(len(face_ids), -1, dtype=np.int64)
    touching = np.zeros(len(face_ids), dtype=np.int64)
    for fi, pi, a in zip(pair_face, pair_patch, pair_area):
        touching[fi] += 1
        if a > best_area[fi]:
            best_area[fi] = a
            best_patch[fi] = pi

    eps = 1e-12
    per_face: List[Dict] = []
    for fi, face in enumerate(face_ids):
        fa = face_area[fi]
        if fa < min_face_fraction * total:
            result["excluded_faces"] += 1
            continue
        bp = best_patch[fi]
        face_fraction = best_area[fi] / fa if fa > 0 else 0.0
        patch_fraction = best_area[fi] / patch_area[bp] if bp >= 0 and patch_area[bp] > 0 else 0.0
        if face_fraction >= threshold - eps and patch_fraction >= threshold - eps:
            status = "correct"
        elif face_fraction >= threshold - eps:
            status = "under"
        else:
            status = "over"
        result[status] += 1
        result["faces"] += 1
        per_face.append({
            "face": int(face),
            "area_fraction": float(fa / total),
            "best_patch": int(patch_ids[bp]) if bp >= 0 else -1,
            "face_fraction": float(face_fraction),
            "patch_fraction": float(patch_fraction),
            "patches_touching": int(touching[fi]),
            "status": status,
        })
    result["per_face"] = per_face
    result["correct_fraction"] = result["correct"] / result["faces"] if result["faces"] else 0.0
    return result


def summarize(results: List[Dict]) -> Dict:
    """Sums the counts of several ``score`` results (e.g. all parts of one variant)."""
    keys = ("faces", "correct", "over", "under", "excluded_faces", "patches", "significant_patches", "gt_faces")
    total = {k: int(sum(r[k] for r in results)) for k in keys}
    total["meshes"] = len(results)
    total["correct_fraction"] = total["correct"] / total["faces"] if total["faces"] else 0.0
    return total
