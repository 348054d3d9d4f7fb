"""Tests of the benchmark's segmentation score (bench/scoring.py) on hand-made label arrays."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

_SPEC = importlib.util.spec_from_file_location(
    "bench_scoring", Path(__file__).resolve().parents[1] / "bench" / "scoring.py")
scoring = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(scoring)


def statuses(result):
    return {f["face"]: f["status"] for f in result["per_face"]}


def test_perfect_segmentation_is_all_correct():
    gt = np.repeat([0, 1, 2], 10)
    labels = np.repeat([7, 3, 5], 10)  # patch ids need not match face ids
    r = scoring.score(labels, gt, np.ones(30))
    assert (r["faces"], r["correct"], r["over"], r["under"]) == (3, 3, 0, 0)
    assert r["patches"] == 3
    assert r["correct_fraction"] == 1.0
    assert statuses(r) == {0: "correct", 1: "correct", 2: "correct"}


def test_split_face_is_over_segmented():
    gt = np.array([0] * 10 + [1] * 10)
    labels = np.array([0] * 5 + [1] * 5 + [2] * 10)  # face 0 split in halves
    r = scoring.score(labels, gt, np.ones(20))
    assert statuses(r) == {0: "over", 1: "correct"}
    assert (r["correct"], r["over"], r["under"]) == (1, 1, 0)
    face0 = r["per_face"][0]
    assert face0["face_fraction"] == pytest.approx(0.5)
    assert face0["patches_touching"] == 2


def test_merged_faces_are_under_segmented():
    gt = np.array([0] * 10 + [1] * 10 + [2] * 10)
    labels = np.array([4] * 20 + [9] * 10)  # faces 0 and 1 in one patch
    r = scoring.score(labels, gt, np.ones(30))
    assert statuses(r) == {0: "under", 1: "under", 2: "correct"}
    assert (r["correct"], r["over"], r["under"]) == (1, 0, 2)
    assert r["per_face"][0]["patch_fraction"] == pytest.approx(0.5)


def test_small_merge_below_threshold_is_still_correct():
    # Patch 0 holds all of face 0 plus a sliver (area 2 of 12) of face 1: 10/12 = 83% >= 80%.
    gt = np.array([0] * 10 + [1] * 10)
    labels = np.array([0] * 12 + [1] * 8)
    r = scoring.score(labels, gt, np.ones(20))
    assert statuses(r) == {0: "correct", 1: "correct"}


def test_transitions_are_not_a_patch():
    gt = np.array([0] * 10 + [1] * 10)
    labels = np.array([-1] * 10 + [1] * 10)  # face 0 entirely transition
    r = scoring.score(labels, gt, np.ones(20))
    assert statuses(r) == {0: "over", 1: "correct"}
    assert r["per_face"][0]["best_patch"] == -1
    assert r["patches"] == 1
    assert r["transition_area_fraction"] == pytest.approx(0.5)
    # Thin transitions (10% of each face) do not spoil correctness.
    labels = np.array([-1] + [0] * 9 + [-1] + [1] * 9)
    r = scoring.score(labels, gt, np.ones(20))
    assert (r["correct"], r["over"], r["under"]) == (2, 0, 0)


def test_overlap_is_measured_by_area_not_triangle_count():
    # Face 0: one big triangle (area 9) in patch 0 and nine small ones (area 1/9 each) in patch 1.
    gt = np.zeros(10, dtype=int)
    labels = np.array([0] + [1] * 9)
    areas = np.array([9.0] + [1.0 / 9.0] * 9)
    r = scoring.score(labels, gt, areas)
    assert r["per_face"][0]["best_patch"] == 0
    assert r["per_face"][0]["face_fraction"] == pytest.approx(0.9)
    assert r["correct"] == 1
    # Weighting by count instead would make the other patch the best one.
    r = scoring.score(labels, gt, np.ones(10))
    assert r["per_face"][0]["best_patch"] == 1


def test_tiny_faces_are_excluded():
    gt = np.array([0] * 999 + [1])  # face 1 has 0.1% of the area by default weighting...
    areas = np.ones(1000)
    areas[-1] = 0.1  # ...now 0.01%: below 0.05%
    labels = np.zeros(1000, dtype=int)
    labels[-1] = 5
    r = scoring.score(labels, gt, areas)
    assert r["faces"] == 1 and r["excluded_faces"] == 1
    assert statuses(r) == {0: "correct"}
    # With no exclusion the tiny face counts (and is correct: its own patch).
    r = scoring.score(labels, gt, areas, min_face_fraction=0.0)
    assert r["faces"] == 2 and r["correct"] == 2


def test_statuses_partition_scored_faces_on_random_labels():
    rng = np.random.default_rng(1)
    gt = rng.integers(0, 20, size=2000)
    labels = np.where(rng.random(2000) < 0.7, gt // 2, rng.integers(-1, 15, size=2000))
    areas = rng.random(2000)
    r = scoring.score(labels, gt, areas)
    assert r["correct"] + r["over"] + r["under"] == r["faces"]
    assert r["faces"] + r["excluded_faces"] == r["gt_faces"] == 20
    # Faces 2k and 2k+1 share patch k: nothing can be correct, all are merged.
    assert r["correct"] == 0
    for f in r["per_face"]:
        assert f["best_patch"] == f["face"] // 2


def test_input_validation():
    with pytest.raises(ValueError):
        scoring.score([0, 1], [0], [1.0, 1.0])
    with pytest.raises(ValueError):
        scoring.score([0], [0], [-1.0])


def test_summarize_adds_counts():
    a = scoring.score([0, 0, 1], [0, 0, 1], [1, 1, 1])
    b = scoring.score([0, 0, 0], [0, 1, 2], [1, 1, 1])
    s = scoring.summarize([a, b])
    assert (s["faces"], s["correct"], s["under"], s["meshes"]) == (5, 2, 3, 2)
    assert s["correct_fraction"] == pytest.approx(0.4)


def test_sampled_radius_follows_the_displacement_outwards():
    """The feature benchmark's radius of a perturbed face: the true radius moved by the mean
    displacement along the normals, outwards from the axis (a boss grows, a hole shrinks), the
    centre or the tube circle."""
    import shapes
    run_features = shapes.bench_module("run_features")
    t = np.linspace(0.0, 2.0 * np.pi, 40, endpoint=False)
    ring = np.column_stack([np.cos(t), np.sin(t), np.zeros_like(t)])
    heights = np.repeat(np.linspace(0.0, 4.0, 5), len(t))
    radial = np.tile(ring, (5, 1))
    boss = 2.0 * radial + np.outer(heights, [0, 0, 1]) + [1.0, -1.0, 0.0]
    cylinder = {"type": "cylinder", "params": {"axis": [0, 0, 2], "point": [1.0, -1.0, 7.0], "radius": 2.0}}
    every = np.arange(len(boss))
    shift = np.full(len(boss), 0.05)
    shift[::2] = 0.03  # the mean counts, not each vertex
    assert run_features.sampled_radius(cylinder, boss, radial, shift, every) == pytest.approx(2.04)
    assert run_features.sampled_radius(cylinder, boss, -radial, shift, every) == pytest.approx(1.96)
    assert run_features.sampled_radius(cylinder, boss, radial, shift, every[:2]) == pytest.approx(2.04)

    sphere = {"type": "sphere", "params": {"center": [0, 0, 0], "radius": 3.0}}
    assert run_features.sampled_radius(sphere, 3.0 * radial, -radial, shift, every) == pytest.approx(2.96)

    # A torus about z, tube circle of radius 5 in z = 0, tube radius 1: points on its outer equator
    # and top, normals out of the tube.
    tube = np.vstack([6.0 * ring, 5.0 * ring + [0, 0, 1]])
    normals = np.vstack([ring, np.tile([0.0, 0.0, 1.0], (len(t), 1))])
    torus = {"type": "torus", "params": {"axis": [0, 0, 1], "center": [0, 0, 0], "major": 5.0, "minor": 1.0}}
    assert run_features.sampled_radius(torus, tube, normals, np.full(len(tube), 0.1),
                                       np.arange(len(tube))) == pytest.approx(1.1)


def _convex_solid(points):
    """Outward-oriented triangles of the convex hull of `points` and the hull's plane equations."""
    from scipy.spatial import ConvexHull
    hull = ConvexHull(points)
    F = hull.simplices.copy()
    V = hull.points
    normals = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    inward = np.einsum("ij,ij->i", normals, V[F].mean(axis=1) - V.mean(axis=0)) < 0
    F[inward] = F[inward][:, ::-1]
    return V, F, hull.equations


def test_marching_cubes_signed_distance_is_exact_at_an_acute_edge():
    """The signed distance the marching-cubes variants contour: exact within the clamp, and signed
    right around a 20-degree wedge, where the closest triangle's plane alone puts points above the
    edge inside (bench/datasets.py, signed_distance_grid)."""
    import shapes
    datasets = shapes.bench_module("datasets")
    a = np.radians(20.0)
    profile = [(0.0, 0.0), (10.0, 0.0), (10.0 * np.cos(a), 10.0 * np.sin(a))]
    V, F, planes = _convex_solid(np.array([(x, y, z) for x, y in profile for z in (0.0, 5.0)]))
    h = 0.37
    origin = V.min(axis=0) - (2 + np.array([0.3, 0.7, 0.1])) * h
    shape = tuple(int(n) for n in np.ceil((V.max(axis=0) + 2 * h - origin) / h).astype(int) + 1)
    values, info = datasets.signed_distance_grid(V, F, origin, shape, h)
    P = origin + h * np.stack(np.nonzero(np.ones(shape, bool)), axis=1)
    inside = np.all(P @ planes[:, :3].T + planes[:, 3] < 0, axis=1)
    distance = np.full(len(P), np.inf)
    for t in F:
        Q, _ = datasets.closest_points_on_triangles(P, *(np.repeat(V[[c]], len(P), axis=0) for c in t))
        distance = np.minimum(distance, np.linalg.norm(P - Q, axis=1))
    expected = np.where(inside, -1.0, 1.0) * np.minimum(distance, datasets.MC_NEAR_CELLS * h)
    assert np.all(np.sign(values.reshape(-1)) == np.where(inside, -1.0, 1.0))
    assert np.allclose(values.reshape(-1), expected, atol=1e-9)
    assert info["voids"] == 0

    Vm, Fm, mc = datasets.marching_cubes_mesh(values, origin, h)
    stats = datasets.edge_statistics(Fm)
    assert stats["boundary_edges"] == stats["nonmanifold_edges"] == stats["misoriented_edges"] == 0
    assert mc["components"] == 1 and not mc["flipped"]
    volume = 0.5 * 10.0 * 10.0 * np.sin(a) * 5.0
    assert datasets.signed_volume(Vm, Fm) == pytest.approx(volume, rel=0.05)


def test_surface_samples_cover_slivers_and_large_triangles():
    """Every point of the surface lies within about one spacing of a sample, for a fan of long
    slivers and for a triangle much larger than the spacing alike, with no more samples than the
    area needs."""
    import shapes
    from scipy.spatial import cKDTree
    datasets = shapes.bench_module("datasets")
    V = np.array([[0.0, 0.0, 0.0]] + [[10.0, y, 0.0] for y in np.linspace(0.0, 0.5, 11)]
                 + [[0.0, 0.0, 1.0], [10.0, 0.0, 1.0], [0.0, 10.0, 1.0]])
    F = np.array([[0, i, i + 1] for i in range(1, 11)] + [[12, 13, 14]])
    spacing = 0.2
    P = datasets.surface_samples(V, F, spacing)
    rng = np.random.default_rng(1)
    r = rng.random((20000, 2))
    r[r.sum(1) > 1] = 1 - r[r.sum(1) > 1]
    t = rng.integers(0, len(F), 20000)
    A, B, C = V[F[t, 0]], V[F[t, 1]], V[F[t, 2]]
    probes = A + r[:, :1] * (B - A) + r[:, 1:] * (C - A)
    assert cKDTree(P).query(probes)[0].max() < 1.5 * spacing
    area = datasets.triangle_areas(V, F).sum()
    assert len(P) < 3 * area / spacing ** 2
