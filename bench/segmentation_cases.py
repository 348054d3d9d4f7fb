"""The thesis's synthetic segmentation cases (Chen & Feng, thesis 3.3.1-3.3.2), rebuilt.

The thesis shows one CAD part three ways: an ideal CAD mesh (figs. 3.9-3.12), the same part with
chamfered edges and noise (a synthesized scan, figs. 3.14-3.16) and with chamfered edges and
undulations (a synthesized sculpt, figs. 3.17-3.18). It does not give the part's drawing or the
noise in millimetres; it gives the facts used here:

- the part has planes, cylinders, spheres, cones, sharp convex edges and concave edge blends, and
  its extremity peaks sit at -0.123 and 0.505 mm^-1 (fig. 3.5); chapter 4's synthetic part is
  60 x 60 x 120 mm with radii of 30 mm;
- real scanning noise is about 0.01 mm^-1 of mean curvature (3.1.2) and the synthetic noise was
  "about 20 times higher than the actual scanning noise" (4.4.1);
- undulations have curvature radii above 100 mm (3.1.2).

So the part here is a 120 x 60 x 25 mm block in a 120 x 60 x 60 mm box: four vertical R8 fillets
(convex cylinders), a R15 boss with a R15 dome (cylinder and tangent sphere) standing on a concave
R4 blend (a torus: H from -0.12 to -0.09 mm^-1, the thesis's -0.123 extremity), and a R8 through
hole with a 3 mm countersink (concave cylinder and cone); all other edges sharp. 15 B-rep faces.

Cases (each mesh labelled with its B-rep face per triangle):

``ideal``
    FreeCAD's tessellation, as a CAD export makes it (linear deflection 0.1 % of the diagonal,
    0.35 rad; the benchmark's ``cad`` setting).
``chamfer``
    A fine tessellation re-sampled by CGAL isotropic remeshing without edge protection
    (``idealize._native.remesh_isotropic``) to about 60 000 triangles (the thesis's real meshes had
    61-75k): every sharp edge becomes a chamfer one triangle wide. Chapter 4's first variant.
``noise``
    ``chamfer`` + Gaussian noise along the vertex normals with sigma = 0.07 mm, which gives the
    raw mean curvature on the planes a spread of 0.2 mm^-1: 20 times the 0.01 mm^-1 of real scans.
``noise-strong``
    sigma = 0.1 % of the diagonal (0.15 mm), the benchmark's ``scan`` level (0.4 mm^-1 spread).
``undulation``
    ``chamfer`` warped by three sinusoids (random directions, wavelengths diag/2..diag), largest
    displacement 0.3 % of the diagonal (0.44 mm): the benchmark's ``sculpt`` amplitude (the
    benchmark displaces along vertex normals; a warp of space keeps the chamfered edges uncreased).
``undulation-large``
    The same waves scaled so that the mean curvature they add reaches 0.01 mm^-1 (a radius of
    100 mm, the thesis's bound for undulations): displacements of several millimetres.

For each case the script runs ``idealize.segment`` and draws ``bench/figures/segcase-<case>.png``:
the histogram of the raw (cotangent) mean curvature, which the thesis's pass 1 reads; the histogram
of the denoised mean curvature, which the code's pass 1 thresholds; the pass-2 histogram exactly as
the segmentation exposes it (``histogram["counts"]`` and the conditioned ``histogram["smoothed"]``
with its kept valleys); the ground truth and the patches with their transition strips. The first
two histograms are built from exposed per-vertex values with the code's own construction (150 bins
over [min, max]); the code itself builds no pass-1 histogram, so there is no conditioned pass-1
histogram to show. Results go to ``bench/results/segmentation_cases.json``.

The perturbed cases are run again with 8 more seeds (``--seeds``), and the spread of their results
is printed and stored. Run with Debian's interpreter from the repository root:
``/usr/bin/python3 bench/segmentation_cases.py`` (about a minute; ``--only noise`` for one case,
``--no-figures`` to skip drawing, ``--seeds 0`` for the figures' seeds only).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Dict, List

import numpy as np

BENCH = Path(__file__).resolve().parent
REPO = BENCH.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(BENCH))

import datasets  # noqa: E402
import scoring  # noqa: E402

FIGURES = BENCH / "figures"
RESULTS = BENCH / "results" / "segmentation_cases.json"

CASES = ("ideal", "chamfer", "noise", "noise-strong", "undulation", "undulation-large")
TRIANGLES = 60_000            # requested from the remeshing (it delivers about 71k)
NOISE_SIGMA_MM = 0.07         # 20 x scanning noise in curvature terms (see the module docstring)
NOISE_STRONG_REL = 1e-3       # x diag, the benchmark's scan noise
UNDULATION_REL = 3e-3         # x diag, largest displacement, the benchmark's sculpt level
UNDULATION_MAX_H = 0.01       # mm^-1, added mean curvature bound of the large undulations
WAVES = 3
SEEDS = 8                     # further noise / undulation realisations, for the spread of the results


# ----------------------------------------------------------------------------------------------
# The part


def build_part():
    """The synthetic part (FreeCAD B-rep) and its 15 faces' surface types."""
    FreeCAD, Part, _, _ = datasets.freecad_modules()
    vec = FreeCAD.Vector

    def circle_at(edge, radius, z, center_x=None):
        try:
            curve = edge.Curve
        except Exception:  # noqa: BLE001  (FreeCAD raises TypeError for some curve types)
            return False
        return (type(curve).__name__ == "Circle" and abs(curve.Radius - radius) < 1e-6
                and abs(edge.Vertexes[0].Point.z - z) < 1e-6
                and (center_x is None or abs(curve.Center.x - center_x) < 1e-6))

    base = Part.makeBox(120, 60, 25)
    vertical = [e for e in base.Edges if abs(e.Vertexes[0].Point.z - e.Vertexes[1].Point.z) > 1.0]
    base = base.makeFillet(8, vertical)
    boss = Part.makeCylinder(15, 20, vec(30, 30, 25))
    dome = Part.makeSphere(15, vec(30, 30, 45))
    solid = base.fuse(boss).fuse(dome).removeSplitter()
    solid = solid.makeFillet(4, [e for e in solid.Edges if circle_at(e, 15, 25)])
    solid = solid.cut(Part.makeCylinder(8, 40, vec(90, 30, -5)))
    solid = solid.makeChamfer(3, [e for e in solid.Edges if circle_at(e, 8, 25, 90)])
    if not solid.isValid() or len(solid.Faces) != 15:
        raise RuntimeError(f"the synthetic part did not build ({len(solid.Faces)} faces)")
    return solid


def face_curvatures(solid) -> List[Dict]:
    """Type and true mean curvature range of every face (convex positive), from FreeCAD's
    curvatureAt on a 5 x 5 parameter grid (OCC's sign is negative on a convex face whose
    orientation is Forward)."""
    out = []
    for face in solid.Faces:
        u0, u1, v0, v1 = face.ParameterRange
        sign = -1.0 if face.Orientation == "Forward" else 1.0
        values = []
        for a in np.linspace(0.05, 0.95, 5):
            for b in np.linspace(0.05, 0.95, 5):
                k1, k2 = face.curvatureAt(u0 + a * (u1 - u0), v0 + b * (v1 - v0))
                values.append(sign * 0.5 * (k1 + k2))
        out.append({"type": type(face.Surface).__name__, "h_low": float(min(values)),
                    "h_high": float(max(values)), "area": float(face.Area)})
    return out


# ----------------------------------------------------------------------------------------------
# The meshes


def remeshed(solid, triangles: int):
    """Fine tessellation re-sampled isotropically (sharp edges become chamfers), labelled by the
    closest fine triangle to each centroid."""
    diag = solid.BoundBox.DiagonalLength
    Vf, Ff, gtf, _ = datasets.tessellate(solid, datasets.FINE_LINEAR_DEFLECTION * diag,
                                         datasets.FINE_ANGULAR_DEFLECTION)
    area = float(datasets.triangle_areas(Vf, Ff).sum())
    length = math.sqrt(4.0 * area / (math.sqrt(3.0) * triangles))
    nat = datasets.native()
    V, F = nat.remesh_isotropic(np.ascontiguousarray(Vf), np.ascontiguousarray(Ff, dtype=np.int32), length,
                                datasets.REMESH_ITERATIONS)
    V = np.ascontiguousarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int32)
    nearest = np.asarray(nat.closest_faces(np.ascontiguousarray(Vf), np.ascontiguousarray(Ff, dtype=np.int32),
                                           np.ascontiguousarray(V[F].mean(axis=1))), dtype=np.int64)
    return V, F, gtf[nearest].astype(np.int32), length


def undulation_warp(V: np.ndarray, diag: float, seed: int):
    """A smooth warp of space: WAVES sinusoids of unit amplitude (random wave directions and
    displacement directions, wavelengths diag/2..diag), as (N, 3) displacements of the vertices, and
    the bound 1/2 sum(k_i^2) of the mean curvature one unit of amplitude per wave adds. A warp of
    space rather than a displacement along vertex normals: normals turn abruptly across a sharp
    edge, and millimetre displacements along them would crease the edges."""
    rng = np.random.default_rng(seed)
    d = np.zeros_like(V)
    bound = 0.0
    for _ in range(WAVES):
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        displacement = rng.normal(size=3)
        displacement /= np.linalg.norm(displacement)
        wavelength = rng.uniform(diag / 2.0, diag)
        k = 2.0 * math.pi / wavelength
        d += np.sin(k * (V @ direction) + rng.uniform(0.0, 2.0 * math.pi))[:, None] * displacement[None, :]
        bound += 0.5 * k * k
    return d, bound


def build_cases(only=None, seeds=(None,)) -> Dict[str, Dict]:
    """The cases by name; with seeds other than None, the perturbed cases (noise, undulations)
    again for every seed, named "<case>@<seed>" (None: the figures' seeds, from the case name)."""
    solid = build_part()
    diag = float(solid.BoundBox.DiagonalLength)
    faces = face_curvatures(solid)
    cases: Dict[str, Dict] = {}
    wanted = [c for c in CASES if not only or c in only]
    if "ideal" in wanted:
        V, F, gt, info = datasets.tessellate(solid, datasets.CAD_LINEAR_DEFLECTION * diag,
                                             datasets.CAD_ANGULAR_DEFLECTION)
        cases["ideal"] = {"V": V, "F": F, "gt": gt,
                          "title": "ideal CAD mesh (thesis 3.3.1)",
                          "how": f"FreeCAD tessellation, deflection {datasets.CAD_LINEAR_DEFLECTION * diag:.3f} mm, "
                                 f"{datasets.CAD_ANGULAR_DEFLECTION} rad"}
    if any(c != "ideal" for c in wanted):
        V0, F, gt, length = remeshed(solid, TRIANGLES)
        normals = datasets.vertex_normals(V0, F)
        base = {"F": F, "gt": gt, "edge_length": length}
        if "chamfer" in wanted:
            cases["chamfer"] = dict(base, V=V0, title="chamfered edges only",
                                    how=f"isotropic remesh, edge {length:.2f} mm")
        for seed in seeds:
            suffix = "" if seed is None else f"@{seed}"
            for name, sigma in (("noise", NOISE_SIGMA_MM), ("noise-strong", NOISE_STRONG_REL * diag)):
                if name in wanted:
                    rng = np.random.default_rng(datasets.stable_seed("segcase", name) if seed is None else seed)
                    V = V0 + normals * rng.normal(0.0, sigma, size=len(V0))[:, None]
                    cases[name + suffix] = dict(
                        base, V=V, sigma=sigma, title=f"chamfered edges + noise, sigma {sigma:.3f} mm (thesis 3.3.2)",
                        how=f"isotropic remesh, edge {length:.2f} mm; Gaussian noise along normals")
            d, bound = undulation_warp(V0, diag, datasets.stable_seed("segcase", "undulation") if seed is None else seed)
            size = np.linalg.norm(d, axis=1)
            for name in ("undulation", "undulation-large"):
                if name in wanted:
                    scale = UNDULATION_REL * diag / size.max() if name == "undulation" else UNDULATION_MAX_H / bound
                    amplitude = float(scale * size.max())
                    cases[name + suffix] = dict(
                        base, V=V0 + scale * d, amplitude=amplitude, added_h=float(scale * bound),
                        title=f"chamfered edges + undulations, up to {amplitude:.2f} mm (thesis 3.3.2)",
                        how=f"isotropic remesh, edge {length:.2f} mm; {WAVES} sinusoidal warps, "
                            f"added |H| <= {scale * bound:.4f} 1/mm")
    for case in cases.values():
        case["faces"] = faces
        case["diag"] = diag
    return cases


# ----------------------------------------------------------------------------------------------
# Running and drawing


def robust_spread(values: np.ndarray) -> float:
    """Standard deviation estimated from the median absolute deviation: blind to the few chamfer
    vertices that the closest-face labels put on a plane."""
    return float(1.4826 * np.median(np.abs(values - np.median(values))))


def run_case(name: str, case: Dict) -> Dict:
    import idealize

    V, F, gt = case["V"], case["F"], case["gt"]
    start = time.perf_counter()
    seg = idealize.segment(idealize.Mesh(V, F))
    seconds = time.perf_counter() - start
    w = seg.working
    Vw, Fw = np.asarray(w["working_vertices"]), np.asarray(w["working_faces"])
    raw = idealize.vertex_curvature(idealize.Mesh(Vw, Fw))["mean"]  # the same operator, no denoising
    areas = datasets.triangle_areas(V, F)
    score = scoring.score(seg.labels, gt, areas)
    # A patch that is no scored face's best patch is a fragment (over-segmentation). The patches'
    # "kind" is not used: it reads "sharp" whenever a folded sharp sliver joined the patch.
    best = {f["best_patch"] for f in score["per_face"] if f["best_patch"] >= 0}
    fragments = [p["id"] for p in seg.patches if p["id"] not in best]
    # Plane vertices of the ground truth at least two rings away from any other face (none on a
    # CAD tessellation, whose planes have no inner vertices), for the spread of raw H the noise
    # gives (the thesis: 0.01 1/mm for real scans).
    plane_faces = [i for i, f in enumerate(case["faces"]) if f["type"] == "Plane"]
    near_other = np.zeros(len(V), dtype=bool)
    near_other[F[~np.isin(gt, plane_faces)].ravel()] = True
    for _ in range(2):
        near_other[F[near_other[F].any(axis=1)].ravel()] = True
    plane_vertices = ~near_other
    plane_vertices[np.setdiff1d(np.arange(len(V)), F.ravel())] = False
    input_h = idealize.vertex_curvature(idealize.Mesh(V, F))["mean"]
    return {
        "seg": seg, "raw_h": raw, "score": score, "seconds": seconds,
        "summary": {
            "triangles": int(len(F)), "working_triangles": int(len(Fw)),
            "faces": len(case["faces"]), "patches": seg.n_patches, "fragments": len(fragments),
            "fragment_area_fraction": float(areas[np.isin(seg.labels, fragments)].sum() / areas.sum()),
            "correct": score["correct"], "over": score["over"], "under": score["under"],
            "scored_faces": score["faces"],
            "transition_area_fraction": float(np.sum(areas[seg.transition]) / areas.sum()),
            "valleys": [float(v) for v in seg.histogram["valleys"]],
            "zero_mean_curvature": [float(v) for v in seg.zero_mean_curvature],
            "raw_h_spread_on_planes": robust_spread(input_h[plane_vertices]) if plane_vertices.any() else None,
            "seconds": seconds,
            "per_face": [{"face": f["face"], "type": case["faces"][f["face"]]["type"], "status": f["status"],
                          "face_fraction": round(f["face_fraction"], 3),
                          "patch_fraction": round(f["patch_fraction"], 3)} for f in score["per_face"]],
        },
    }


def _truth_marks(ax, faces: List[Dict]) -> None:
    """The faces' true mean curvatures: a line per constant value, a band per varying one."""
    seen = set()
    for f in faces:
        lo, hi = f["h_low"], f["h_high"]
        key = (round(lo, 4), round(hi, 4))
        if key in seen:
            continue
        seen.add(key)
        if hi - lo < 1e-6:
            ax.axvline(lo, color="0.55", lw=0.8, ls=":", zorder=0)
        else:
            ax.axvspan(lo, hi, color="0.85", zorder=0)


def _histogram_panel(ax, values: np.ndarray, title: str, faces: List[Dict], thresholds=None, bins: int = 150):
    counts, edges = np.histogram(values, bins=bins, range=(float(values.min()), float(values.max())))
    centres = 0.5 * (edges[:-1] + edges[1:])
    _truth_marks(ax, faces)
    ax.plot(centres, counts, color="tab:blue", lw=1.0, drawstyle="steps-mid")
    for t in thresholds or ():
        ax.axvline(t, color="tab:red", lw=0.8, ls="--")
    ax.set_yscale("symlog", linthresh=10.0)
    ax.set_ylim(bottom=0.0)
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("mean curvature H (1/mm)", fontsize=9)
    ax.set_ylabel("vertices per bin (symlog)", fontsize=9)
    ax.tick_params(labelsize=8)


def _pass2_panel(ax, hist: Dict, faces: List[Dict]):
    counts = np.asarray(hist["counts"])
    smoothed = np.asarray(hist["smoothed"])
    width = (hist["high"] - hist["low"]) / len(counts)
    centres = hist["low"] + (np.arange(len(counts)) + 0.5) * width
    _truth_marks(ax, faces)
    ax.plot(centres, counts, color="0.6", lw=0.8, drawstyle="steps-mid", label="counts (smoothed H)")
    ax.plot(centres, smoothed, color="tab:blue", lw=1.2, label="conditioned (eq. 1)")
    for v in hist["valleys"]:
        ax.axvline(v, color="tab:red", lw=0.8, ls="--")
    peaks = np.asarray(hist["peak_bins"], dtype=int)
    ax.plot(centres[peaks], smoothed[peaks], "v", color="tab:green", ms=5, label="range peaks")
    ax.set_yscale("symlog", linthresh=10.0)
    ax.set_ylim(bottom=0.0)
    ax.set_title(f"pass 2: exposed histogram, {len(hist['valleys'])} kept valleys (red)", fontsize=10)
    ax.set_xlabel("smoothed mean curvature H (1/mm)", fontsize=9)
    ax.set_ylabel("vertices per bin (symlog)", fontsize=9)
    ax.tick_params(labelsize=8)
    ax.legend(fontsize=7, loc="upper right")


def draw_case(name: str, case: Dict, result: Dict) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import run_segmentation as rs

    seg = result["seg"]
    w = seg.working
    faces = case["faces"]
    edge = float(np.median(np.linalg.norm(case["V"][case["F"][:, 1]] - case["V"][case["F"][:, 0]], axis=1)))
    panel = 6.0
    fig = plt.figure(figsize=(3 * panel, 2 * panel), dpi=100)
    ax = fig.add_subplot(2, 3, 1)
    _histogram_panel(ax, result["raw_h"], "raw H (no denoising): what the thesis's pass 1 reads", faces)
    ax = fig.add_subplot(2, 3, 2)
    H = np.asarray(w["mean_curvature"])
    wV, wF = np.asarray(w["working_vertices"]), np.asarray(w["working_faces"])
    wedge = float(np.mean(np.linalg.norm(wV[wF[:, 1]] - wV[wF[:, 0]], axis=1)))
    limit = 1.0 / (4.0 * wedge)
    _histogram_panel(ax, H, "denoised H: the code's pass 1 (red: +-1/(4 L) at mean L)", faces, (-limit, limit))
    ax = fig.add_subplot(2, 3, 3)
    _pass2_panel(ax, seg.histogram, faces)

    V, F = case["V"], case["F"]
    cull = rs.cull_sign(V, F)
    view = rs.choose_view(V, F, case["gt"])
    ax = fig.add_subplot(2, 3, 4, projection="3d")
    rs._draw(ax, V, F, case["gt"], f"ground truth: {len(faces)} faces", cull, view)
    shown = np.where(seg.transition, -1, seg.labels)
    s = result["summary"]
    ax = fig.add_subplot(2, 3, 5, projection="3d")
    rs._draw(ax, V, F, shown, f"{s['patches']} patches, transition strips dark red", cull, view)
    ax = fig.add_subplot(2, 3, 6)
    ax.set_axis_off()
    wrong = [f"{f['type']} {f['face']}: {f['status']} ({f['face_fraction']:.2f}/{f['patch_fraction']:.2f})"
             for f in s["per_face"] if f["status"] != "correct"]
    lines = [case["title"], case["how"], "",
             f"{s['triangles']} triangles ({s['working_triangles']} after refinement), median edge {edge:.2f} mm",
             "raw H spread on the planes: " + ("n/a (no inner vertices)" if s["raw_h_spread_on_planes"] is None
                                               else f"{s['raw_h_spread_on_planes']:.3f} 1/mm"),
             f"patches: {s['patches']}, of which {s['fragments']} fragments",
             f"  (fragment: no face's best patch; {100 * s['fragment_area_fraction']:.1f} % of the area)",
             f"faces: {s['faces']}; correct {s['correct']}, over {s['over']}, under {s['under']}",
             f"transition strips: {100 * s['transition_area_fraction']:.1f} % of the area",
             "kept valleys: " + ", ".join(f"{v:.3f}" for v in s["valleys"]),
             f"zero range of H: {s['zero_mean_curvature'][0]:.4f} .. {s['zero_mean_curvature'][1]:.4f}",
             "", "not correct (face/patch share):"] + (wrong or ["none"]) + [
             "", "histograms: 150 bins over [min, max]; grey dotted lines", "and bands: the faces' true H"]
    ax.text(0.0, 1.0, "\n".join(lines), va="top", ha="left", fontsize=9, family="monospace", wrap=True,
            transform=ax.transAxes)
    fig.suptitle(f"segcase {name}: {case['title']}", fontsize=13)
    fig.subplots_adjust(left=0.05, right=0.98, bottom=0.02, top=0.93, wspace=0.22, hspace=0.12)
    path = FIGURES / f"segcase-{name}.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    rs._shrink_png(path)
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--only", action="append", choices=CASES, help="run only this case (repeatable)")
    parser.add_argument("--no-figures", action="store_true")
    parser.add_argument("--seeds", type=int, default=SEEDS,
                        help=f"also run the perturbed cases with this many other seeds (default {SEEDS})")
    args = parser.parse_args(argv)
    cases = build_cases(args.only, (None,) + tuple(range(args.seeds)))
    results, spread = {}, {}
    print(f"{'case':18s} {'tris':>7s} {'faces':>5s} {'patches':>7s} {'fragm.':>6s} {'correct':>7s} {'over':>4s} {'under':>5s}")
    for name, case in cases.items():
        result = run_case(name, case)
        s = result["summary"]
        if "@" in name:
            spread.setdefault(name.split("@")[0], []).append({k: s[k] for k in ("correct", "patches", "fragments")})
            continue
        results[name] = dict(s, title=case["title"], how=case["how"])
        print(f"{name:18s} {s['triangles']:7d} {s['faces']:5d} {s['patches']:7d} {s['fragments']:6d} "
              f"{s['correct']:7d} {s['over']:4d} {s['under']:5d}")
        if not args.no_figures:
            draw_case(name, case, result)
    if spread:
        print(f"\nover {args.seeds} more seeds (min / median / max):")
        for name, rows in spread.items():
            text = "  ".join(f"{k} {min(r[k] for r in rows)} / {int(np.median([r[k] for r in rows]))} / "
                             f"{max(r[k] for r in rows)}" for k in ("correct", "patches", "fragments"))
            print(f"{name:18s} {text}")
            results[name]["seeds"] = rows
    if not args.only:
        faces = next(iter(cases.values()))["faces"]
        RESULTS.parent.mkdir(parents=True, exist_ok=True)
        RESULTS.write_text(json.dumps({"faces": faces, "cases": results}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
