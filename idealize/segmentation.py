"""Automatic feature segmentation (mean-curvature histograms, Chen & Feng 2014)."""
import numpy as np

from ._loader import native
from .mesh import Mesh, MeshError


class Segmentation:
    """Result of :func:`segment`.

    labels: (M,) int32, one patch id per input triangle in input order; -1 only on degenerate
    triangles and where no patch can be reached. The one-triangle-wide transition strips that
    border the patches are folded into them, so patches meet along edge polylines.
    transition: (M,) bool, the triangles that formed those strips before folding.
    features: list of dicts, one per patch: id, kind ("smooth", "sharp_convex", "sharp_concave"),
    triangles, area, mean_curvature, curvature_range.
    timings: seconds per stage.
    working: the refined mesh the analysis ran on and its per-vertex curvature, for later stages.
    """

    def __init__(self, result):
        self.labels = result.pop("labels")
        self.transition = result.pop("transition")
        self.features = result.pop("patches")
        self.timings = dict(result.pop("timings"))
        self.removed_degenerate = result.pop("removed_degenerate")
        self.removed_duplicate = result.pop("removed_duplicate")
        self.histogram = result.pop("histogram")
        self.zero_mean_curvature = tuple(result.pop("zero_mean_curvature"))
        self.mesh_check = {key: result.pop(key) for key in ("shells", "boundary_edges", "nonmanifold_edges")}
        self.working = result

    @property
    def n_features(self):
        return len(self.features)

    def __repr__(self):
        return "<idealize.Segmentation %d features, %d of %d triangles on transition strips>" % (
            self.n_features, int(np.count_nonzero(self.transition)), len(self.labels))


def segment(mesh, progress=None):
    """Segment a mesh into feature patches, fully automatically (no parameters).

    progress: an :class:`idealize.Progress` that another thread may read (``fraction`` goes from
    the start to the end of its ``range``, 0 to 1 unless set, ``stage`` names the step) and
    ``cancel()``; a cancelled run raises :class:`idealize.Cancelled`. The GIL is released while
    the native code runs.
    """
    if not isinstance(mesh, Mesh):
        raise TypeError("segment() takes an idealize.Mesh (see idealize.load_mesh), got %s"
                        % type(mesh).__name__)
    if mesh.n_triangles == 0:
        raise MeshError("the mesh has no triangles")
    return Segmentation(native.segment(mesh.vertices, mesh.faces, progress=progress))
