"""The fitted B-rep of a feature layer: analytic faces trimmed by the intersections of adjacent
ideal surfaces, one solid when they close (native/src/brep/brep.h)."""
import time

import numpy as np

from ._loader import native
from .features import as_feature_layer, count_summary


class Solid:
    """Result of :func:`make_solid`.

    valid: OpenCASCADE's checker accepts the shape. closed: no free edges. solid: a valid closed
    solid (otherwise `shape` holds only the faces that could be made, as a shell or compound).
    faces, volume (0 unless solid), surface_types: face count per type ("facet" counts the planar
    facets of faceted regions). problems: list of (feature id or -1, message) for what failed.
    face_features: the feature of each face. regions: per region of the mesh, a dict with its
    feature, the kind of its face ("analytic", "bspline" or "faceted": its triangles, where its
    surface gave no valid face), the reason when faceted, and its area. analytic_area_fraction: the
    share of the mesh's area on analytic faces. joined: (feature, the feature it joined) for each
    feature whose region a neighbour's surface explained as well as its own (no face of its own).
    euler: {"solid", "mesh"}, the Euler characteristic V - E + F of the solid's faces and of the
    mesh (2 - 2 genus per body; 0 both without a solid): where they differ, a problem says so.
    max_deviation: largest distance from the input mesh vertices to the shape's faces.
    Honest validity (measured by the construction on a closed valid shape, 0 otherwise):
    mesh_to_shape and shape_to_mesh, the two-sided distance between the mesh and the faces;
    deviation_bound, the largest distance any face was allowed from its part of the mesh (its fit,
    or the distance of its border from the edges that replace it, plus the tolerance); mesh_volume,
    the volume the mesh encloses. `solid` holds only within those bounds.
    max_tolerance: largest vertex or edge tolerance, the widest gap between the faces' boundaries
    that the shape bridges (beyond the layer's distance tolerance, viewers may leave faces out).
    """

    def __init__(self, brep, layer, max_deviation, deflection, timings):
        self._brep = brep
        self.layer = layer
        self.valid = brep.valid
        self.closed = brep.closed
        self.solid = brep.solid
        self.faces = brep.faces
        self.volume = brep.volume
        self.max_tolerance = brep.max_tolerance
        self.surface_types = dict(brep.surface_types)
        self.problems = list(brep.problems)
        self.joined = list(brep.joined)
        self.euler = {"solid": int(brep.euler_shape), "mesh": int(brep.euler_mesh)}
        self.face_features = list(brep.face_features)
        self.regions = list(brep.regions)
        self.analytic_area_fraction = float(brep.analytic_area_fraction)
        self.mesh_to_shape = float(brep.mesh_to_shape)
        self.shape_to_mesh = float(brep.shape_to_mesh)
        self.deviation_bound = float(brep.deviation_bound)
        self.mesh_volume = float(brep.mesh_volume)
        self.max_deviation = max_deviation
        self.deviation_deflection = deflection
        self.timings = timings

    def failed_features(self):
        """Ids of the features named in the problems."""
        return sorted({feature for feature, _ in self.problems if feature >= 0})

    def brep_string(self):
        """The shape as OCCT BRep text (bytes)."""
        return self._brep.brep_string()

    def write_step(self, path):
        """Write the shape to a STEP file (AP214, millimetres, faces coloured by type)."""
        self._brep.write_step(str(path))

    def triangulate(self, deflection):
        """(V, F) triangulation of the faces with chordal deviation at most `deflection`."""
        return self._brep.triangulate(float(deflection))

    def part_shape(self):
        """The shape as a FreeCAD ``Part.Shape`` (needs FreeCAD)."""
        import FreeCAD  # noqa: F401  (FreeCAD before Part)
        import Part
        shape = Part.Shape()
        shape.importBrepFromString(self.brep_string().decode("ascii"), False)
        return shape

    def report(self):
        """The report's "brep" entry."""
        return {
            "valid": bool(self.valid),
            "closed": bool(self.closed),
            "solid": bool(self.solid),
            "faces": int(self.faces),
            "volume": float(self.volume),
            "surface_types": {k: int(v) for k, v in sorted(self.surface_types.items())},
            "max_deviation": float(self.max_deviation),
            "max_tolerance": float(self.max_tolerance),
            "analytic_area_fraction": float(self.analytic_area_fraction),
            "deviation": {"mesh_to_solid": self.mesh_to_shape, "solid_to_mesh": self.shape_to_mesh,
                          "bound": self.deviation_bound},
            "mesh_volume": self.mesh_volume,
            "faces_by_kind": {k: sum(r["kind"] == k for r in self.regions) for k in ("analytic", "bspline", "faceted")},
            "faceted": [{"feature": int(r["feature"]), "reason": r["reason"], "area": float(r["area"])}
                        for r in self.regions if r["kind"] == "faceted"],
            "problems": [{"feature": int(f), "message": m} for f, m in self.problems],
            "joined": [{"feature": int(f), "into": int(into)} for f, into in self.joined],
            "euler": dict(self.euler),
        }

    def __repr__(self):
        state = "solid" if self.solid else ("invalid" if not self.valid else "open shell")
        return "<idealize.Solid %s, %d faces (%s), volume %.6g>" % (
            state, self.faces, count_summary(self.surface_types), self.volume)


# Shares of make_solid: building the B-rep, triangulating it, and measuring the distances of the
# mesh vertices from the triangulation (measured on a scan of a million triangles).
BREP_SHARE = 0.45
TRIANGULATION_SHARE = 0.05


def make_solid(layer, tolerance=None, progress=None):
    """Build the fitted B-rep of a :class:`idealize.FeatureLayer` (or of a feature layer document
    object, see :func:`idealize.make_feature_layer`).

    tolerance: distance below which geometry is equal; default the layer's distance tolerance.
    progress: an :class:`idealize.Progress` that another thread may read and cancel; its
    ``fraction`` goes once from the start to the end of its ``range`` (0 to 1 unless set) over the
    call. A cancelled run raises :class:`idealize.Cancelled`.
    """
    layer = as_feature_layer(layer)
    tolerance = layer.distance_tolerance if tolerance is None else float(tolerance)
    if not tolerance > 0:
        raise ValueError("the tolerance must be positive")
    if progress is None:
        return _make_solid(layer, tolerance, None)
    caller_range = progress.range
    try:
        return _make_solid(layer, tolerance, progress)
    finally:
        progress.set_range(*caller_range, restart=False)


def _make_solid(layer, tolerance, progress):
    mesh = layer.mesh
    if progress is not None:
        start, end = progress.range
        brep_end = start + BREP_SHARE * (end - start)
        triangulation_end = brep_end + TRIANGULATION_SHARE * (end - start)
        progress.set_range(start, brep_end)  # the bar starts over with this call
    start_time = time.perf_counter()
    types = [f["type"] for f in layer.features]
    params = [dict(f["params"]) for f in layer.features]
    # The triangles with the segmentation's orientation repair.
    # What the layer decided about the mesh and the angle tolerance it used (None for a layer stored
    # without them: the B-rep judges the kind from the fit, and takes the default angle).
    brep = native.build_brep(mesh.vertices, layer.oriented_faces, np.asarray(layer.labels, dtype=np.int32),
                             types, params, tolerance, progress=progress, mesh_kind=layer.mesh_kind,
                             angle_tolerance=layer.angle_tolerance)
    timings = dict(brep.timings)
    timings["brep"] = time.perf_counter() - start_time
    start_time = time.perf_counter()
    deflection = 0.1 * tolerance
    max_deviation = float("nan")
    if brep.faces:
        if progress is not None:
            progress.set_range(brep_end, triangulation_end, restart=False)
        V, F = brep.triangulate(deflection, progress=progress)
        if len(F):
            if progress is not None:
                progress.set_range(triangulation_end, end, restart=False)
            max_deviation = float(np.max(native.mesh_distances(V, F, mesh.vertices, progress=progress)))
    if progress is not None:
        progress.set_range(start, end, restart=False)
        progress.report("done", 1.0)
    timings["brep.deviation"] = time.perf_counter() - start_time
    return Solid(brep, layer, max_deviation, deflection, timings)
