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
        suggested), best_fit (type and params of the best analytic fit, also for freeform),
        radius_error (standard error of the fitted radius of a cylinder or sphere, of a torus's
        tube radius; 0 for the other types).
    adjacency: list of {"a", "b", "continuity" ("G0" sharp or "G1" tangent), "angle", "length"}.
    relations: list of {"kind", "features"}: parallel, coplanar, coaxial, equal_radius and
        concentric groups; perpendicular and tangent pairs of adjacent features.
    idealized_vertices: (N, 3) the input vertices moved onto their features' surfaces; the
        triangles are the input's. deviation: {"max", "rms"} distance of the input vertices from
        the surfaces of their features; vertex_deviation: (N,) that distance per vertex (NaN where
        only freeform features touch it). form_deviation: how far the mesh departs from its fitted
        surfaces other than by independent noise (a sculpted part's undulation; about 0 on a scan).
    mesh_kind: "exact tessellation" (its vertices lie on their faces, as a CAD export's) or "measured
        surface" (a scan, a sculpted or remeshed mesh), decided once from the typical patch's fit;
        noise: that patch's spread (distance), normal_noise: its normals' (radians). The B-rep reads
        the kind. angle_tolerance: the one used, in degrees (the B-rep's too).
    segmentation: the :class:`idealize.Segmentation` the layer was built from (None for a layer
        restored from a document object).
    mesh_check: the segmentation's mesh checks (dict, see :class:`idealize.Segmentation`), None
        without a segmentation. oriented_faces: the input's triangles with its orientation repair
        (the input's own array when nothing was turned over); the B-rep is built on them.
    """

    def __init__(self, mesh, segmentation, result):
        self.mesh = mesh
        self.segmentation = segmentation
        self.labels = result["labels"]
        self.features = result["features"]
        self.adjacency = result["adjacency"]
        self.relations = result["relations"]
        self.idealized_vertices = result["idealized_vertices"]
        self.vertex_deviation = result["vertex_deviation"]
        self.deviation = {"max": result["max_deviation"], "rms": result["rms_deviation"]}
        self.distance_tolerance = result["distance_tolerance"]
        self.form_deviation = result.get("form_deviation")  # None from a layer stored without it
        # Decided once by the feature stages, read by the B-rep (None from a layer stored without it).
        self.mesh_kind = result.get("mesh_kind")
        self.angle_tolerance = result.get("angle_tolerance_degrees")
        self.noise = result.get("noise")
        self.normal_noise = result.get("normal_noise")
        self.mesh_check = segmentation.mesh_check if segmentation is not None else None
        # The input's triangles with the orientation repair applied (the input's own when none).
        self.oriented_faces = segmentation.oriented_faces(mesh.faces) if segmentation is not None else mesh.faces
        # Per feature: the edge length an edit's remeshing keeps (set by idealize.edit, so that
        # successive edits keep the first one's density); None for a layer not edited.
        self.edge_lengths = None
        self.timings = dict(segmentation.timings) if segmentation is not None else {}
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


# The share of a whole run that segmentation takes (measured on scans of 40k to 1M triangles).
SEGMENTATION_SHARE = 0.6


def split_range(progress, share):
    """Split the range of `progress` at `share`: ((start, middle), (middle, end))."""
    start, end = progress.range
    middle = start + share * (end - start)
    return (start, middle), (middle, end)


# The defaults of the options a user sets, from the native core (FeatureOptions): no second copy.
DEFAULTS = native.feature_defaults()


def idealize(mesh, segmentation=None, progress=None, angle_tolerance=DEFAULTS["angle_tolerance_degrees"],
             distance_tolerance=None, radius_tolerance=DEFAULTS["radius_tolerance"],
             idealize_relations=DEFAULTS["idealize"], self_intersections=False, measured=False):
    """Segment (unless a segmentation is given), identify and relate features, project the mesh.

    The options rarely need changing. angle_tolerance (degrees): directions closer than this are
    parallel or perpendicular, and snap to the part's ideal directions; distance_tolerance: axes,
    centres, radii and offsets closer than this are equal (None: 0.1 % of the bounding-box
    diagonal); radius_tolerance: radii within this fraction of each other are one design radius;
    idealize_relations: make the relations exact (False: the fitted surfaces stay as they are).
    self_intersections: have the segmentation's mesh check count crossing triangle pairs (see
    :func:`idealize.segment`; the command line does). measured: the mesh is not an exact
    tessellation even where most of it looks like one (a sculpted region with the CAD faces around
    it, as :func:`idealize.reidealize` passes it).

    progress: an :class:`idealize.Progress` that another thread may read and cancel. Its
    ``fraction`` goes once from the start to the end of its ``range`` (0 to 1 unless set) over the
    whole call: segmentation fills the first 60 %, identification the rest (all of it when a
    segmentation is given). A cancelled run raises :class:`idealize.Cancelled`.
    """
    if not 0 < angle_tolerance < 45:
        raise ValueError("the angle tolerance must be between 0 and 45 degrees, got %r" % angle_tolerance)
    if distance_tolerance is not None and not distance_tolerance > 0:
        raise ValueError("the distance tolerance must be positive (or None for automatic), got %r"
                         % distance_tolerance)
    if not 0 <= radius_tolerance < 1:
        raise ValueError("the radius tolerance is a fraction between 0 and 1, got %r" % radius_tolerance)
    options = {"angle_tolerance_degrees": float(angle_tolerance), "distance_tolerance": float(distance_tolerance or 0.0),
               "radius_tolerance": float(radius_tolerance), "idealize": bool(idealize_relations),
               "measured": bool(measured)}
    if progress is None:
        return _idealize(mesh, segmentation, None, options, self_intersections)
    caller_range = progress.range
    try:
        return _idealize(mesh, segmentation, progress, options, self_intersections)
    finally:
        progress.set_range(*caller_range, restart=False)


def _idealize(mesh, segmentation, progress, options, self_intersections=False):
    given = segmentation is not None
    if progress is not None:
        first, second = split_range(progress, 0.0 if given else SEGMENTATION_SHARE)
        progress.set_range(*first)  # the bar starts over with this call
    if not given:
        segmentation = segment(mesh, progress=progress, self_intersections=self_intersections)
    if progress is not None:
        progress.set_range(*second, restart=False)
    mean = [p["mean_curvature"] for p in segmentation.patches]
    gaussian = [p["mean_gaussian"] for p in segmentation.patches]
    low, high = segmentation.zero_mean_curvature
    # Identification and the B-rep see the triangles with the segmentation's orientation repair.
    faces = segmentation.oriented_faces(mesh.faces)
    result = native.identify_features(mesh.vertices, faces, np.asarray(segmentation.labels),
                                      mean, gaussian, low, high, progress=progress, **options)
    return FeatureLayer(mesh, segmentation, result)


def as_feature_layer(layer):
    """A :class:`FeatureLayer` as is, or the one a feature layer document object holds (its proxy
    makes it: the core imports nothing of FreeCAD)."""
    if isinstance(layer, FeatureLayer):
        return layer
    proxy = getattr(layer, "Proxy", None)
    if getattr(proxy, "Type", None) == "IdealizeFeatureLayer" and hasattr(proxy, "feature_layer"):
        return proxy.feature_layer(layer)
    raise TypeError("expected an idealize.FeatureLayer or a feature layer document object, got %s"
                    % type(layer).__name__)
