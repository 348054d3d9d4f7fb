"""The feature layer: typed features with exact parameters, their graph, and the idealized mesh."""
import numpy as np

from ._loader import native
from .mesh import Mesh
from .segmentation import segment


def count_summary(counts):
    """"2 cylinder, 6 plane" from {"plane": 6, "cylinder": 2}: counts per type, for messages."""
    return ", ".join("%d %s" % (n, t) for t, n in sorted(counts.items()))


class FeatureLayer:
    """Result of :func:`idealize`.

    labels: (M,) int32, the feature of every input triangle: the segmentation's patches, with rim
        triangles that a neighbouring feature's surface explains better moved to it.
    features: list of dicts, one per feature: id, type (plane, cylinder, cone, sphere, torus,
        freeform), params (plane normal/point, cylinder axis/point/radius, cone axis/apex/
        half_angle in radians, sphere center/radius, torus axis/center/major/minor), rms and
        max_error of the fit, area, triangles, curvature_type (the type the curvature signs
        suggested), best_fit (type and params of the best analytic fit, also for freeform).
    adjacency: list of {"a", "b", "continuity" ("G0" sharp or "G1" tangent), "angle", "length"}.
    relations: list of {"kind", "features"}: parallel, coplanar, coaxial, equal_radius and
        concentric groups; perpendicular and tangent pairs of adjacent features.
    idealized_vertices: (N, 3) the input vertices moved onto their features' surfaces; the
        triangles are the input's. deviation: {"max", "rms"} distance of the input vertices from
        the surfaces of their features.
    segmentation: the :class:`idealize.Segmentation` the layer was built from.
    """

    def __init__(self, mesh, segmentation, result):
        self.mesh = mesh
        self.segmentation = segmentation
        self.labels = result["labels"]
        self.features = result["features"]
        self.adjacency = result["adjacency"]
        self.relations = result["relations"]
        self.idealized_vertices = result["idealized_vertices"]
        self.deviation = {"max": result["max_deviation"], "rms": result["rms_deviation"]}
        self.distance_tolerance = result["distance_tolerance"]
        self.timings = dict(segmentation.timings)
        self.timings.update(("features." + name, seconds) for name, seconds in result["timings"])

    def idealized_mesh(self):
        """The idealized mesh as an :class:`idealize.Mesh` (input connectivity)."""
        return Mesh(self.idealized_vertices, self.mesh.faces, source=self.mesh.source)

    def type_counts(self):
        counts = {}
        for feature in self.features:
            counts[feature["type"]] = counts.get(feature["type"], 0) + 1
        return counts

    def __repr__(self):
        return "<idealize.FeatureLayer %d features (%s), %d relations>" % (
            len(self.features), count_summary(self.type_counts()), len(self.relations))


def idealize(mesh, segmentation=None):
    """Segment (unless a segmentation is given), identify and relate features, project the mesh."""
    if segmentation is None:
        segmentation = segment(mesh)
    mean = [p["mean_curvature"] for p in segmentation.features]
    gaussian = [p["mean_gaussian"] for p in segmentation.features]
    low, high = segmentation.zero_mean_curvature
    result = native.identify_features(mesh.vertices, mesh.faces, np.asarray(segmentation.labels),
                                      mean, gaussian, low, high)
    return FeatureLayer(mesh, segmentation, result)
