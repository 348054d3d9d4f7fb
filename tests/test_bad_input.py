"""Bad meshes get a clear MeshError or a documented repair, never a crash."""
import numpy as np
import pytest

import idealize
import shapes


def segment(V, F, **options):
    return idealize.segment(idealize.Mesh(np.asarray(V, float), np.asarray(F)), **options)


def test_nan_and_inf_coordinates():
    V, F = shapes.icosphere(subdivisions=1)
    for bad in (np.nan, np.inf):
        W = V.copy()
        W[3, 1] = bad
        with pytest.raises(idealize.MeshError, match="NaN or infinity"):
            segment(W, F)


def test_no_triangles_and_bad_indices():
    with pytest.raises(idealize.MeshError, match="no triangles"):
        segment(np.zeros((3, 3)), np.zeros((0, 3), int))
    with pytest.raises(idealize.MeshError, match="refer to vertex"):
        idealize.Mesh(np.zeros((3, 3)), [[0, 1, 5]])
    with pytest.raises(idealize.MeshError, match=r"\(M, 3\)"):
        idealize.Mesh(np.zeros((3, 3)), [[0, 1]])


def test_only_degenerate_triangles():
    V = [[0, 0, 0], [1, 0, 0], [2, 0, 0]]
    with pytest.raises(idealize.MeshError, match="degenerate"):
        segment(V, [[0, 1, 2], [0, 0, 1]])


def test_degenerate_and_duplicate_triangles_are_repaired():
    V, F = shapes.icosphere(subdivisions=3)
    extra_vertex = len(V)
    V = np.vstack([V, V[0]])                      # a duplicate vertex position
    F2 = np.vstack([F, [[0, 0, 1]], F[5:6], [[0, 1, extra_vertex]]])
    seg = segment(V, F2)
    base = segment(V[:-1], F)
    assert np.array_equal(seg.labels[: len(F)], base.labels)
    assert seg.labels[len(F)] == -1               # repeated vertex: degenerate, not labelled
    assert seg.labels[len(F) + 1] == seg.labels[5]  # duplicate: the label of the face it repeats
    assert seg.removed_degenerate == 2 and seg.removed_duplicate == 1


def test_wrong_argument_type():
    with pytest.raises(TypeError, match="idealize.Mesh"):
        idealize.segment("part.stl")


# ---- Mesh checks and repairs (README "Mesh checks and repairs") ----

def test_absurd_scales_are_rejected_with_the_probable_unit_problem():
    V, F = shapes.icosphere(subdivisions=2)
    with pytest.raises(idealize.MeshError, match="collapsed to a point.*scale factor"):
        segment(V * 1e-12, F)                         # 2e-12 across
    with pytest.raises(idealize.MeshError, match="collapsed to a point"):
        segment(np.zeros_like(V), F)                  # every vertex at one place
    with pytest.raises(idealize.MeshError, match="coordinates reach 1e\\+40.*overflow"):
        segment(V * 1e40, F)
    with pytest.raises(idealize.MeshError, match="lies .* from the origin.*move the part near the origin"):
        segment(V + [1e8, 0.0, 0.0], F)               # 3.5 across (diagonal), 1e8 away
    # Unused vertices far away do not count: only what the triangles use.
    segment(np.vstack([V, [[1e35, 0.0, 0.0]]]), F)


@pytest.mark.parametrize("scale, offset", [(0.05, 0.0), (5e3, 0.0), (1e-6, 0.0), (1.0, 1e5)])
def test_real_units_still_work(scale, offset):
    """A 0.1 m part in metres, a 10 mm part in micrometres, a micro-part in metres, an offset part."""
    V, F = shapes.icosphere(subdivisions=3)
    reference = segment(V, F)
    seg = segment(V * scale + offset, F)
    assert seg.n_patches == reference.n_patches
    assert seg.mesh_check["shells"] == 1 and seg.mesh_check["flipped_faces_repaired"] == 0


def test_open_boundary_several_shells_and_nonmanifold_edges():
    V1, F1 = shapes.icosphere(radius=1.0, subdivisions=3)
    V2, F2 = shapes.tube(radius=1.0, length=3.0)     # open at both ends
    V2 = V2 + [5.0, 0.0, 0.0]
    V = np.vstack([V1, V2])
    F = np.vstack([F1, F2 + len(V1)])
    # A fin glued onto one sphere edge makes that edge non-manifold.
    a, b = F1[0, 0], F1[0, 1]
    V = np.vstack([V, [[3.0, 3.0, 3.0]]])
    F = np.vstack([F, [[a, b, len(V) - 1]]])
    seg = segment(V, F)
    check = seg.mesh_check
    assert {k: check[k] for k in ("shells", "boundary_edges", "nonmanifold_edges")} == \
        {"shells": 3, "boundary_edges": 2 * 64 + 2, "nonmanifold_edges": 1}
    # Two rims of 64 edges and the fin's two free edges; the fin's faces join the sphere's fan.
    assert check["boundary_loops"] == 3 and check["largest_hole_edges"] == 64
    assert check["nonmanifold_vertices"] == 0
    assert check["inconsistent_edges"] == 0 and check["flipped_faces_repaired"] == 0
    labels = seg.labels
    sphere_labels = set(labels[: len(F1)]) - {-1}
    tube_labels = set(labels[len(F1): len(F1) + len(F2)]) - {-1}
    assert sphere_labels and tube_labels and not (sphere_labels & tube_labels)


def test_nonmanifold_vertex_is_counted_and_kept():
    """Two spheres touching at one shared vertex (a pinch): two fans at that vertex."""
    V1, F1 = shapes.icosphere(radius=1.0, subdivisions=2)
    top = int(np.argmax(V1[:, 2]))
    V2 = 2.0 * V1[top] - V1                         # the first sphere mirrored through its vertex `top`
    index = np.arange(len(V2)) + len(V1)
    index[top] = top
    V = np.vstack([V1, V2])
    F = np.vstack([F1, index[F1]])
    seg = segment(V, F, self_intersections=True)
    assert seg.mesh_check["nonmanifold_vertices"] == 1
    assert seg.mesh_check["closed_shells_turned_outward"] == 1   # mirroring turned it inside out
    assert seg.mesh_check["shells"] == 2 and seg.mesh_check["nonmanifold_edges"] == 0
    assert seg.mesh_check["boundary_edges"] == 0 and seg.mesh_check["self_intersecting_pairs"] == 0
    assert np.all(seg.labels >= 0)


@pytest.fixture(scope="module")
def bracket():
    """A CAD tessellation of a block with a through hole and four rounds: convex and concave."""
    if shapes.freecad() is None:
        pytest.skip("FreeCAD is not installed")
    V, F, _ = shapes.tessellate_with_faces(shapes.bracket_solid(), 0.05)
    return V, F


def flip(F, which):
    F = F.copy()
    F[which] = F[which][:, [0, 2, 1]]
    return F


def test_flipped_triangles_are_reoriented_before_curvature(bracket):
    """Half of a closed mesh's triangles turned over: same labels and curvature signs as the clean
    mesh (mean curvature's sign tells convex from concave, so a wrong orientation would swap them)."""
    V, F = bracket
    clean = segment(V, F)
    assert clean.mesh_check["inconsistent_edges"] == 0 and clean.mesh_check["flipped_faces_repaired"] == 0
    rng = np.random.default_rng(3)
    which = rng.permutation(len(F))[: len(F) // 2]
    flipped = segment(V, flip(F, which))
    check = flipped.mesh_check
    assert check["inconsistent_edges"] > len(F) // 4
    assert check["flipped_faces_repaired"] == len(which)      # closed: outward wins, not the majority
    assert check["nonorientable_shells"] == 0
    assert np.array_equal(flipped.labels, clean.labels)
    assert [f["kind"] for f in flipped.patches] == [f["kind"] for f in clean.patches]
    assert np.allclose([f["mean_curvature"] for f in flipped.patches],
                       [f["mean_curvature"] for f in clean.patches])
    # Inside out as a whole: every face turned back, the shell counted as turned outward.
    inside_out = segment(V, F[:, [0, 2, 1]])
    assert inside_out.mesh_check["flipped_faces_repaired"] == len(F)
    assert inside_out.mesh_check["closed_shells_turned_outward"] == 1
    assert inside_out.mesh_check["inconsistent_edges"] == 0
    assert np.array_equal(inside_out.labels, clean.labels)
    # The repair works on a copy: the caller's arrays are untouched.
    F_flipped = flip(F, which)
    before = F_flipped.copy()
    mesh = idealize.Mesh(V, F_flipped)
    idealize.segment(mesh)
    assert np.array_equal(mesh.faces, before) and np.array_equal(F_flipped, before)


def test_open_mesh_keeps_its_majority_orientation():
    V, F = shapes.tube(radius=1.0, length=3.0)
    which = np.arange(0, len(F), 7)                      # a seventh of the faces turned over
    seg = segment(V, flip(F, which))
    assert seg.mesh_check["flipped_faces_repaired"] == len(which)
    assert np.array_equal(seg.labels, segment(V, F).labels)


def test_self_intersections_are_counted_not_repaired():
    V, F = shapes.icosphere(radius=1.0, subdivisions=2)
    assert segment(V, F).mesh_check["self_intersecting_pairs"] == -1     # not counted unless asked
    assert segment(V, F, self_intersections=True).mesh_check["self_intersecting_pairs"] == 0
    # A second sphere overlapping the first: their surfaces cross along a circle.
    seg = segment(np.vstack([V, V + [1.0, 0.0, 0.0]]), np.vstack([F, F + len(V)]), self_intersections=True)
    assert seg.mesh_check["self_intersecting_pairs"] > 10
    assert seg.mesh_check["self_intersections_capped"] is False
    assert seg.mesh_check["shells"] == 2
    # Two triangles folded onto each other along their shared edge overlap too; touching at a
    # shared vertex or edge alone is no intersection.
    Vf = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, 0.8, 0.0], [0, -1, 0]], float)
    for F2, pairs in (([[0, 1, 2], [1, 0, 3]], 1), ([[0, 1, 2], [1, 0, 4]], 0)):
        assert segment(Vf, F2, self_intersections=True).mesh_check["self_intersecting_pairs"] == pairs


def test_feature_layer_and_cli_report_carry_the_checks(tmp_path):
    import json
    import os
    import subprocess
    import sys
    from data_builders import write_binary_stl
    V, F = shapes.icosphere(radius=10.0, subdivisions=3)
    F = flip(F, np.arange(0, len(F), 3))
    layer = idealize.idealize(idealize.Mesh(V, F), self_intersections=True)   # as the command line does
    assert layer.mesh_check == layer.segmentation.mesh_check
    assert layer.mesh_check["flipped_faces_repaired"] == len(range(0, len(F), 3))
    path, report = tmp_path / "sphere.stl", tmp_path / "report.json"
    write_binary_stl(path, V, F)
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    result = subprocess.run([sys.executable, "-m", "idealize", "convert", str(path), "-o", str(tmp_path / "o.step"),
                             "--report", str(report)], cwd=root, capture_output=True, text=True, timeout=300)
    assert result.returncode in (0, 1), result.stderr
    data = json.loads(report.read_text())
    assert data["repairs"]["orientation_fixed"] == layer.mesh_check["flipped_faces_repaired"]
    assert data["mesh_check"] == layer.mesh_check and data["mesh_check"]["self_intersecting_pairs"] == 0
    assert {"degenerate_triangles_ignored", "duplicate_triangles_merged"} <= set(data["repairs"])


def test_meshes_beyond_the_memory_available_are_refused(monkeypatch):
    """A mesh whose processing would exhaust memory is refused with a message, before any work."""
    from idealize import mesh as mesh_module
    V, F = shapes.icosphere(subdivisions=3)
    monkeypatch.setattr(mesh_module, "available_memory", lambda: mesh_module.BASE_BYTES + 100 * len(F))
    with pytest.raises(idealize.MeshError, match=r"1280 triangles: processing it needs about .* GB of memory"):
        idealize.segment(idealize.Mesh(V, F))
    monkeypatch.setattr(mesh_module, "available_memory", lambda: 2 * mesh_module.BASE_BYTES)
    assert idealize.segment(idealize.Mesh(V, F)).n_patches >= 1
    # 5.5 million triangles fit into 8 GB (measured peak 3.56 GB), 20 million do not.
    mesh_module.check_size(5_500_000, available=8e9)
    with pytest.raises(idealize.MeshError, match="decimate"):
        mesh_module.check_size(20_000_000, available=8e9)


def test_mesh_check_summary_names_findings_and_repairs():
    from idealize.freecad.mesh import mesh_check_summary
    check = {"shells": 2, "boundary_edges": 9, "nonmanifold_edges": 1, "nonmanifold_vertices": 0, "boundary_loops": 2,
             "largest_hole_edges": 6, "inconsistent_edges": 4, "flipped_faces_repaired": 3,
             "closed_shells_turned_outward": 0, "nonorientable_shells": 0, "self_intersecting_pairs": 5,
             "self_intersections_capped": False, "degenerate_removed": 1, "duplicate_removed": 0,
             "unused_vertices_removed": 0}
    assert mesh_check_summary(check) == ("Mesh: 2 shells, 2 holes (largest 6 edges), 1 non-manifold edge, "
                                         "5 self-intersecting triangle pairs; repaired: 3 triangles turned over, "
                                         "1 degenerate triangle set aside")
