"""Bad meshes get a clear MeshError or a documented repair, never a crash."""
import numpy as np
import pytest

import idealize
import shapes


def segment(V, F):
    return idealize.segment(idealize.Mesh(np.asarray(V, float), np.asarray(F)))


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
    assert seg.mesh_check == {"shells": 3, "boundary_edges": 2 * 64 + 2, "nonmanifold_edges": 1}
    labels = seg.labels
    sphere_labels = set(labels[: len(F1)]) - {-1}
    tube_labels = set(labels[len(F1): len(F1) + len(F2)]) - {-1}
    assert sphere_labels and tube_labels and not (sphere_labels & tube_labels)


def test_wrong_argument_type():
    with pytest.raises(TypeError, match="idealize.Mesh"):
        idealize.segment("part.stl")
