"""What-if runs behind the proposals of docs/segmentation-check.md, on the synthetic cases of
bench/segmentation_cases.py.

The native segmentation cannot be changed from Python, so this script replays its pass 2 in numpy
from the values the segmentation exposes (denoised mean curvature, pass-2 smoothed curvature and
histogram, working mesh) and varies one step at a time:

- the ripple threshold of the valley test (the code's median, the counting-noise floor alone, the
  thesis's eq. (2) read literally: mean peak-to-valley difference of raw counts);
- the width below which a patch is dissolved as a sliver (the code: no face with all three
  vertices inside; "2 rings": no face two rings inside);
- the number of smoothing iterations: 60 instead of 15 for both histogram and classes, or 5 for
  the values that are *classified* only (the histogram and its valleys stay those of the code's
  15 iterations).

The replay is a proxy, not the native pipeline: it reproduces the histogram conditioning and the
valleys exactly (checked below), the vertex classes and the connected components, but folds the
transition triangles by a plain edge-adjacent "most similar mean curvature" sweep instead of the
native two-stage thinning. It is printed next to the native result so that its own bias shows.
Only differences between proxy rows mean something.

Also prints where a literal reading of the thesis's pass 1 (eq. 1 conditioning, eq. 2 ripple
test, the valleys next to the extremity peaks) would cut the raw and the denoised histograms.

Run: ``/usr/bin/python3 bench/segmentation_proposals.py`` (about two minutes; ``--seeds 0`` for the
figures' meshes only).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

BENCH = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH))

import datasets  # noqa: E402
import scoring  # noqa: E402
import segmentation_cases as cases_module  # noqa: E402

BINS = 150
PASSES = 100
COUNTING_NOISE = 1.5  # 3 sigma of sqrt(Poisson counts), as in histogram.cpp


# ----------------------------------------------------------------------------------------------
# Histogram analysis: histogram.cpp in numpy, plus the literal thesis variant


def histogram(values: np.ndarray):
    low, high = float(values.min()), float(values.max())
    width = (high - low) / BINS
    bins = np.minimum(BINS - 1, ((values - low) / width).astype(int))
    return np.bincount(bins, minlength=BINS).astype(float), low, width


def condition(h: np.ndarray) -> np.ndarray:
    """Eq. (1): a local peak or valley that differs from both neighbours by less than the average
    fluctuation takes the mean of itself and its neighbours; up to 100 passes."""
    h = h.copy()
    for _ in range(PASSES):
        average = np.abs(np.diff(h)).sum() / len(h)
        left, right = h[1:-1] - h[:-2], h[1:-1] - h[2:]
        extremum = ((left > 0) & (right > 0)) | ((left < 0) & (right < 0))
        smooth = extremum & (np.abs(left) < average) & (np.abs(right) < average)
        if not smooth.any():
            break
        nxt = h.copy()
        nxt[1:-1][smooth] = ((h[:-2] + h[1:-1] + h[2:]) / 3.0)[smooth]
        h = nxt
    return h


def extrema(h: np.ndarray):
    """[bin, height, is_peak], alternating, plateaus once, outside counts as lower."""
    out, n, start = [], len(h), 0
    while start < n:
        end = start
        while end + 1 < n and h[end + 1] == h[start]:
            end += 1
        before = h[start - 1] if start > 0 else -np.inf
        after = h[end + 1] if end + 1 < n else -np.inf
        middle = (start + end) // 2
        if h[start] > before and h[start] > after:
            out.append([middle, float(h[start]), True])
        if h[start] < before and h[start] < after:
            out.append([middle, float(h[start]), False])
        start = end + 1
    return out


def valley_bins(smoothed: np.ndarray, rule: str):
    """Kept valley bins. rule: "code" (sqrt counts, median threshold, floor, persistence),
    "floor" (the same with the counting-noise floor alone), "thesis" (eq. 2 literally: mean
    |peak - valley| of raw counts; the text leaves open whether a valley must be that much below
    one or both of its peaks, so the lenient reading is taken: one)."""
    ext = extrema(smoothed)
    if rule == "thesis":
        diffs = [abs(ext[i][1] - ext[i + 1][1]) for i in range(len(ext) - 1)]
        threshold = float(np.mean(diffs)) if diffs else 0.0
        return [ext[i][0] for i in range(1, len(ext) - 1, 2)
                if max(ext[i - 1][1], ext[i + 1][1]) - ext[i][1] >= threshold]
    for e in ext:
        e[1] = float(np.sqrt(max(e[1], 0.0)))
    threshold = COUNTING_NOISE
    if rule == "code" and len(ext) > 1:
        diffs = sorted(abs(ext[i][1] - ext[i + 1][1]) for i in range(len(ext) - 1))
        threshold = max(threshold, diffs[len(diffs) // 2])
    while len(ext) >= 3:
        depths = [(min(ext[i - 1][1], ext[i + 1][1]) - ext[i][1], i) for i in range(1, len(ext) - 1, 2)]
        depth, i = min(depths)
        if depth >= threshold:
            break
        lower = i - 1 if ext[i - 1][1] < ext[i + 1][1] else i + 1
        for k in sorted((lower, i), reverse=True):
            del ext[k]
    return [e[0] for e in ext[1::2]]


def thesis_pass1_cut(values: np.ndarray):
    """Eq. (1) + eq. (2) literally on a histogram of all vertices; the two cuts of pass 1 are the
    valleys next to the first and the last kept peak (None where no valley survives)."""
    counts, low, width = histogram(values)
    bins = valley_bins(condition(counts), "thesis")
    if not bins:
        return None
    return low + (bins[0] + 0.5) * width, low + (bins[-1] + 0.5) * width


# ----------------------------------------------------------------------------------------------
# Pass-2 replay


class Replay:
    def __init__(self, case, seg):
        w = seg.working
        self.V = np.asarray(w["working_vertices"])
        self.F = np.asarray(w["working_faces"]).astype(np.int64)
        self.origin = np.asarray(w["working_face_origin"])
        self.H = np.asarray(w["mean_curvature"])
        self.Hs = np.asarray(w["smoothed_mean_curvature"])
        self.case = case
        self.hist = seg.histogram
        V, F, nv = self.V, self.F, len(self.V)
        edges = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
        edges.sort(axis=1)
        key = edges[:, 0] * nv + edges[:, 1]
        order = np.argsort(key, kind="stable")
        face = np.tile(np.arange(len(F)), 3)[order]
        same = key[order][1:] == key[order][:-1]
        self.adjacent = (face[:-1][same], face[1:][same])
        unique = np.unique(edges, axis=0)
        length = np.linalg.norm(V[unique[:, 0]] - V[unique[:, 1]], axis=1)
        local = (np.bincount(unique.ravel(), np.repeat(length, 2), nv)
                 / np.maximum(np.bincount(unique.ravel(), minlength=nv), 1))
        limit = 1.0 / (4.0 * local)  # radius below two local edge lengths
        self.vclass = np.full(nv, -1)
        self.vclass[self.H < -limit] = 0
        self.vclass[self.H > limit] = 1
        self.non_sharp = self.vclass < 0
        self.interior = self.non_sharp.copy()
        self.interior[F[~self.non_sharp[F].all(axis=1)].ravel()] = False
        self.edges = unique
        import idealize
        # Mixed areas of the working mesh (the native smoothing uses those of the denoised copy).
        self.area = idealize.vertex_curvature(idealize.Mesh(self.V, self.F.astype(np.int32)))["area"]

    def smoothed(self, iterations: int) -> np.ndarray:
        e, active, area = self.edges, self.interior, self.area
        m = active[e[:, 0]] & active[e[:, 1]]
        n = len(self.H)
        A = coo_matrix((np.ones(2 * m.sum()), (np.r_[e[m, 0], e[m, 1]], np.r_[e[m, 1], e[m, 0]])), shape=(n, n)).tocsr()
        cur = self.H.copy()
        for _ in range(iterations):
            den = area + A @ area
            cur = np.where(active, (area * cur + A @ (area * cur)) / np.where(den > 0, den, 1.0), cur)
        return cur

    def run(self, valleys, values=None, sliver_rings: int = 1):
        F, nf = self.F, len(self.F)
        hs = self.Hs if values is None else values
        cls = self.vclass.copy()
        cls[self.non_sharp] = 2 + np.searchsorted(np.asarray(valleys), hs[self.non_sharp], side="right")
        fc = np.where((cls[F[:, 0]] == cls[F[:, 1]]) & (cls[F[:, 1]] == cls[F[:, 2]]), cls[F[:, 0]], -1)
        a, b = self.adjacent
        keep = (fc[a] == fc[b]) & (fc[a] >= 0)
        graph = coo_matrix((np.ones(keep.sum()), (a[keep], b[keep])), shape=(nf, nf))
        _, component = connected_components(graph, directed=False)
        label = np.where(fc >= 0, component, -1)
        # Slivers: a patch keeps only if some face lies `sliver_rings` rings inside it.
        first = np.full(len(self.V), -2)
        first[F.ravel()] = np.repeat(label, 3)
        pure = np.ones(len(self.V), dtype=bool)
        for c in range(3):
            np.logical_and.at(pure, F[:, c], first[F[:, c]] == label)
        core = (label >= 0) & pure[F].all(axis=1)
        for _ in range(sliver_rings - 1):
            bad = np.zeros(len(self.V), dtype=bool)
            bad[F[~core].ravel()] = True
            core &= ~bad[F].any(axis=1)
        has_core = np.zeros(label.max() + 2, dtype=bool)
        has_core[label[core]] = True
        label = np.where((label >= 0) & has_core[np.maximum(label, 0)], label, -1)
        # Fold: transition faces join the edge-adjacent patch of most similar mean curvature.
        fh = hs[F].mean(axis=1)
        ok = label >= 0
        n_labels = label.max() + 1
        mean = np.bincount(label[ok], fh[ok], n_labels) / np.maximum(np.bincount(label[ok], minlength=n_labels), 1)
        while (label < 0).any():
            x = np.r_[a, b]
            y = np.r_[b, a]
            m = (label[x] < 0) & (label[y] >= 0)
            if not m.any():
                break
            x, lab = x[m], label[y[m]]
            d = np.abs(fh[x] - mean[lab])
            order = np.lexsort((d, x))
            x, lab = x[order], lab[order]
            firsts = np.r_[True, x[1:] != x[:-1]]
            label[x[firsts]] = lab[firsts]
        # Map back by area.
        area = datasets.triangle_areas(self.V, F)
        width = label.max() + 2
        key = self.origin.astype(np.int64) * width + (label + 1)
        uniq, inverse = np.unique(key, return_inverse=True)
        shares = np.bincount(inverse, weights=area)
        origin, patch = uniq // width, uniq % width - 1
        out = np.full(len(self.case["F"]), -1)
        for o, p in zip(*[arr[np.lexsort((shares, origin))] for arr in (origin, patch)]):
            out[o] = p
        return scoring.score(out, self.case["gt"], datasets.triangle_areas(self.case["V"], self.case["F"]))


def main(argv=None) -> int:
    import argparse

    import idealize

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=cases_module.SEEDS,
                        help="also replay the perturbed cases with this many other seeds")
    args = parser.parse_args(argv)
    cases = cases_module.build_cases(seeds=(None,) + tuple(range(args.seeds)))
    print("Literal thesis pass 1 (eq. 1 + eq. 2, valleys next to the extremity peaks), figures' meshes:")
    rows = []
    for name, case in cases.items():
        seg = idealize.segment(idealize.Mesh(case["V"], case["F"]))
        replay = Replay(case, seg)
        if "@" not in name:
            raw = idealize.vertex_curvature(idealize.Mesh(replay.V, replay.F.astype(np.int32)))["mean"]
            edge = np.median(np.linalg.norm(replay.V[replay.edges[:, 0]] - replay.V[replay.edges[:, 1]], axis=1))
            fmt = lambda cut: "none" if cut is None else f"{cut[0]:+.3f} / {cut[1]:+.3f}"  # noqa: E731
            print(f"  {name:17s} raw H: {fmt(thesis_pass1_cut(raw)):17s} denoised H: "
                  f"{fmt(thesis_pass1_cut(replay.H)):17s} (the code: |H| > 1/(4 L) = {1.0 / (4.0 * edge):.2f})")
        # The replay must reproduce the exposed conditioning and valleys.
        hist = seg.histogram
        assert np.allclose(condition(np.asarray(hist["counts"], dtype=float)), hist["smoothed"])
        assert valley_bins(np.asarray(hist["smoothed"]), "code") == list(hist["valley_bins"])
        low, width = hist["low"], (hist["high"] - hist["low"]) / BINS
        to_values = lambda bins: [low + (b + 0.5) * width for b in bins]  # noqa: E731
        smoothed = np.asarray(hist["smoothed"])
        floor = to_values(valley_bins(smoothed, "floor"))
        light = np.where(replay.interior, replay.smoothed(5), replay.Hs)
        heavy = replay.smoothed(60)
        counts, heavy_low, heavy_width = histogram(heavy[replay.interior])
        heavy_valleys = [heavy_low + (b + 0.5) * heavy_width for b in valley_bins(condition(counts), "code")]
        row = {"case": name.split("@")[0],
               "native": scoring.score(seg.labels, case["gt"], datasets.triangle_areas(case["V"], case["F"])),
               "proxy": replay.run(hist["valleys"]),
               "thesis eq.2": replay.run(to_values(valley_bins(smoothed, "thesis"))),
               "60 passes": replay.run(heavy_valleys, np.where(replay.interior, heavy, replay.Hs)),
               "A floor": replay.run(floor),
               "B 2 rings": replay.run(hist["valleys"], sliver_rings=2),
               "C classify 5 it.": replay.run(hist["valleys"], light),
               "B+C": replay.run(hist["valleys"], light, sliver_rings=2),
               "A+B": replay.run(floor, sliver_rings=2),
               "A+B+C": replay.run(floor, light, sliver_rings=2)}
        rows.append(row)
    columns = [k for k in rows[0] if k != "case"]
    names = list(dict.fromkeys(r["case"] for r in rows))
    print(f"\nMean correct faces / mean patches over {1 + args.seeds} meshes per perturbed case "
          "(figures' seed + seeds); 15 faces:")
    print(f"  {'case':17s}" + "".join(f"{c:>17s}" for c in columns))
    for name in names:
        mine = [r for r in rows if r["case"] == name]
        print(f"  {name:17s}" + "".join(
            f"{np.mean([r[c]['correct'] for r in mine]):>10.1f} / {np.mean([r[c]['patches'] for r in mine]):<5.1f}"
            for c in columns))
    print(f"  {'mean over cases':17s}" + "".join(
        f"{np.mean([np.mean([r[c]['correct'] for r in rows if r['case'] == n]) for n in names]):>10.1f}       "
        for c in columns))
    return 0


if __name__ == "__main__":
    sys.exit(main())
