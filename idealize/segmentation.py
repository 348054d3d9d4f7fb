"""Automatic feature segmentation (mean-curvature histograms, Chen & Feng 2014)."""
import numpy as np

from ._loader import native
from .mesh import Mesh, MeshError, check_size


class Segmentation:
    """Result of :func:`segment`.

    labels: (M,) int32, one patch id per input triangle in input order; -1 only on degenerate
    triangles and where no patch can be reached. The one-triangle-wide transition strips that
    border the patches are folded into them, so patches meet along edge polylines.
    transition: (M,) bool, the triangles that formed those strips before folding.
    patches: list of dicts, one per patch: id, kind ("smooth", "sharp_convex", "sharp_concave"),
    triangles, area, mean_curvature, curvature_range. (Patches, not features: identification,
    :func:`idealize.idealize`, makes features of them.)
    timings: seconds per stage.
    mesh_check: dict, what the checks before processing found (docs/mesh-checks.md):
    shells, boundary_edges, boundary_loops, largest_hole_edges, nonmanifold_edges,
    nonmanifold_vertices (kept as they are); inconsistent_edges (adjacent triangles running along
    their shared edge the same way), flipped_faces_repaired, closed_shells_turned_outward,
    nonorientable_shells (orientation, repaired on the working copy); self_intersecting_pairs
    (reported; -1 unless segment() was asked to count them; counting stops at 100000, then
    self_intersections_capped is True);
    degenerate_removed, duplicate_removed, unused_vertices_removed (set aside).
    input_flipped: (M,) bool, the input triangles the orientation repair turned over, or None.
    working: the refined mesh the analysis ran on and its per-vertex curvature, for later stages.
    """

    def __init__(self, result):
        self.labels = result.pop("labels")
        self.transition = result.pop("transition")
        self.patches = result.pop("patches")
        self.timings = dict(result.pop("timings"))
        self.removed_degenerate = result.pop("removed_degenerate")
        self.removed_duplicate = result.pop("removed_duplicate")
        self.histogram = result.pop("histogram")
        self.zero_mean_curvature = tuple(result.pop("zero_mean_curvature"))
        self.mesh_check = dict(result.pop("mesh_check"))
        self.input_flipped = result.pop("input_flipped")
        self.working = result

    def oriented_faces(self, faces):
        """`faces` (the input's triangles) with the orientation repair applied: a new array with the
        triangles the repair turned over listed the other way round, or `faces` itself when none
        was (the input is never modified)."""
        if self.input_flipped is None:
            return faces
        oriented = np.array(faces, dtype=np.int32, copy=True)
        oriented[self.input_flipped] = oriented[self.input_flipped][:, [0, 2, 1]]
        return oriented

    @property
    def n_patches(self):
        return len(self.patches)

    def __repr__(self):
        return "<idealize.Segmentation %d patches, %d of %d triangles on transition strips>" % (
            self.n_patches, int(np.count_nonzero(self.transition)), len(self.labels))


def segment(mesh, progress=None, self_intersections=False, part_share=1.0):
    """Segment a mesh into feature patches, fully automatically (no parameters).

    self_intersections: also count the pairs of triangles that cross each other
    (``mesh_check["self_intersecting_pairs"]``, -1 when not counted). Off by default: it costs
    about 1.2 µs per triangle, 40 % of a segmentation of 100k triangles, 12 % of one of a million.
    part_share: the share of a whole part's surface that the mesh is, for a region of a part
    segmented alone (:func:`idealize.reidealize`). A coarse mesh is refined to a minimum sampling
    of the whole part; a region takes its share of it, as densely as the part would be sampled.

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
    check_size(mesh.n_triangles)
    return Segmentation(native.segment(mesh.vertices, mesh.faces, progress=progress,
                                       self_intersections=bool(self_intersections),
                                       part_share=float(part_share)))
