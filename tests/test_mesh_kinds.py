"""What kind of mesh a layer takes an input for, and what the exact path does with CAD exports."""
import numpy as np

import idealize
import shapes
from shapes import needs_shared_data
from test_features import benchmark_surface_score


@needs_shared_data
def test_cad_export_stays_exact_when_segmentation_joins_faces():
    """A CAD export is an exact tessellation even where the segmentation joins faces across edges in
    most of its patches (its fillets' coarse facets): the patches that cover one face still fit
    exactly. The median patch did not, and the part, taken for a measured surface, lost most faces.
    Its sculpted variant, which undulates, is measured."""
    name = "as_isolated_blends_test_28.step"
    _, layer, _, score = benchmark_surface_score(name, "cad")
    assert layer.mesh_kind == "exact tessellation"
    assert score["correct"] >= 0.9 * score["faces"], score["correct"]
    sculpt = shapes.benchmark_mesh(name, "sculpt")
    assert idealize.idealize(idealize.Mesh(sculpt.V, sculpt.F)).mesh_kind == "measured surface"


def test_box_faces_stay_flat_for_curvature():
    """A box's tessellation has no folds but its edges: denoising, which measures its range kernel
    on the folds, must not smooth across them. Every vertex off the box's edges then has zero mean
    curvature, as its faces are flat (before, the edges' folds bled up to 0.04 into the faces)."""
    _, Part, _ = shapes.freecad()
    V, F, _ = shapes.tessellate_with_faces(Part.makeBox(10, 20, 30), 0.1)
    seg = idealize.segment(idealize.Mesh(V, F))
    WV = seg.working["working_vertices"]
    H = seg.working["mean_curvature"]
    on_edge = (np.isclose(WV, 0.0) | np.isclose(WV, [10.0, 20.0, 30.0])).sum(axis=1) >= 2
    assert (~on_edge).sum() > 0.5 * len(WV)
    assert np.abs(H[~on_edge]).max() < 1e-9
    assert np.abs(H[on_edge]).max() > 0.1  # the edges themselves are sharp


@needs_shared_data
def test_single_facets_nothing_placed_form_freeform_features():
    """On a coarse CAD export whose curved faces no analytic surface explains exactly, the single
    facets that merging leaves on their own and that meet without a crease are one freeform feature,
    not a plane each: no two single-facet planes meet at a turn under 45 degrees."""
    mesh = idealize.load_mesh(shapes.SHARED_STEP.parent / "mesh" / "MachinedPart2.stl")
    layer = idealize.idealize(mesh)
    assert layer.mesh_kind == "exact tessellation"
    V, F, labels = np.asarray(mesh.vertices), np.asarray(mesh.faces), np.asarray(layer.labels)
    counts = np.bincount(labels[labels >= 0], minlength=len(layer.features))
    single = np.array([f["type"] == "plane" and counts[i] == 1 for i, f in enumerate(layer.features)])
    normals = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    edges = {}
    for f, face in enumerate(F):
        for k in range(3):
            edges.setdefault(tuple(sorted((face[k], face[(k + 1) % 3]))), []).append(f)
    smooth_pairs = [(f, g) for f, g in (fs for fs in edges.values() if len(fs) == 2)
                    if labels[f] >= 0 and labels[g] >= 0 and labels[f] != labels[g] and single[labels[f]]
                    and single[labels[g]] and normals[f] @ normals[g] > np.cos(np.pi / 4)]
    assert smooth_pairs == []
    assert sum(f["type"] == "freeform" for f in layer.features) >= 1
