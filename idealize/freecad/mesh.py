"""FreeCAD document side of Idealize, without any GUI.

Importable without FreeCAD installed: FreeCAD modules are imported inside the functions. Works in
freecadcmd as well as in the GUI; the GUI commands (idealize.gui) only add display and undo.
"""
import colorsys
import itertools

import numpy as np

from .._loader import native
from ..features import idealize
from ..mesh import Mesh, MeshError
from ..segmentation import segment

# The thesis's colour code for the surface types (RGB in 0..1), from the one table in the core
# (fit/surface.h), which the STEP export reads too.
SURFACE_COLORS = native.surface_colors()
TRANSITION_COLOR = (1.0, 0.0, 0.0)   # edges / transition triangles: red

# Deviation map: colour stops from 0 (blue, on the surface) to the legend's top value (red).
DEVIATION_STOPS = np.array([(0.0, 0.2, 0.8), (0.0, 0.75, 0.75), (0.2, 0.8, 0.2), (1.0, 0.9, 0.0), (0.9, 0.0, 0.0)])


def deviation_colors(values, top):
    """(len(values), 3) RGB in 0..1 for deviations: linear through DEVIATION_STOPS from 0 to `top`,
    clamped above; NaN (no analytic surface to measure from) in the freeform grey."""
    values = np.asarray(values, dtype=np.float64)
    known = np.isfinite(values)
    t = np.clip(np.where(known, values, 0.0) / top if top > 0 else 0.0, 0.0, 1.0) * (len(DEVIATION_STOPS) - 1)
    low = np.minimum(np.floor(t).astype(int), len(DEVIATION_STOPS) - 2)
    w = (t - low)[..., None]
    colors = (1.0 - w) * DEVIATION_STOPS[low] + w * DEVIATION_STOPS[low + 1]
    colors[~known] = SURFACE_COLORS["freeform"]
    return colors

# Name of the per-facet colour property on segmented meshes. ViewProviderMesh (0.20) shows the
# first App::PropertyColorList of a Mesh::Feature per facet when its length equals the facet
# count and the view property Coloring is on.
FACE_COLORS = "FaceColors"


def mesh_from_freecad(mesh):
    """idealize.Mesh from a Mesh::Feature (its .Mesh is used) or a Mesh.Mesh.

    Triangle i of the result is facet i of the FreeCAD mesh, so per-triangle results map back
    one to one. Coordinates are global (the object's placement is applied).
    """
    kernel = getattr(mesh, "Mesh", mesh)
    if not hasattr(kernel, "Topology"):
        raise TypeError("expected a Mesh::Feature or a Mesh.Mesh, got %s" % type(mesh).__name__)
    points, facets = kernel.Topology
    # Flattening the Vector/tuple sequences into fromiter is several times faster than
    # np.array() on the nested sequences (about 0.1 s for 360k facets).
    vertices = np.fromiter(itertools.chain.from_iterable(points), dtype=np.float64,
                           count=3 * len(points)).reshape(-1, 3)
    faces = np.fromiter(itertools.chain.from_iterable(facets), dtype=np.int32,
                        count=3 * len(facets)).reshape(-1, 3)
    return Mesh(vertices, faces, source=getattr(mesh, "Label", None))


def usable_mesh(obj):
    """:func:`mesh_from_freecad`, refusing a mesh without triangles."""
    mesh = mesh_from_freecad(obj)
    if mesh.n_triangles == 0:
        raise MeshError("%s has no triangles" % (mesh.source or "the mesh"))
    return mesh


def segment_mesh_object(obj):
    """Segment a Mesh::Feature (or Mesh.Mesh); labels follow its facet order."""
    return segment(usable_mesh(obj))


def idealize_mesh_object(obj):
    """The feature layer (:class:`idealize.FeatureLayer`) of a Mesh::Feature or Mesh.Mesh."""
    return idealize(usable_mesh(obj))


def type_colors(features, labels):
    """(M, 3) RGB in 0..1: every triangle in the thesis colour of its feature's type, red where
    it belongs to no feature (labels -1)."""
    palette = np.array([SURFACE_COLORS[f["type"]] for f in features] + [TRANSITION_COLOR])
    labels = np.asarray(labels)
    return palette[np.where(labels >= 0, labels, len(features))]


def feature_table(layer):
    """One line of text per feature: id, type, key parameters, RMS residual."""
    lines = []
    for f in layer.features:
        p = f["params"]
        if f["type"] == "plane":
            key = "normal (%.3f, %.3f, %.3f)" % tuple(p["normal"])
        elif f["type"] in ("cylinder", "sphere"):
            key = "radius %.4g" % p["radius"]
        elif f["type"] == "cone":
            key = "half angle %.2f deg" % np.degrees(p["half_angle"])
        elif f["type"] == "torus":
            key = "radii %.4g / %.4g" % (p["major"], p["minor"])
        else:
            key = ""
        lines.append("%4d  %-8s %-32s rms %.3g  (%d triangles)" % (f["id"], f["type"], key, f["rms"], f["triangles"]))
    return lines


def mesh_check_summary(check):
    """One line of what the mesh checks found and repaired (see README "Mesh checks and repairs")."""
    if not check:
        return "mesh check: not available"

    def count(n, what, plural=None):
        return "%d %s" % (n, what if n == 1 else (plural or what + "s"))
    found = [count(check["shells"], "shell")]
    if check["boundary_loops"]:
        found.append("%s (largest %d edges)" % (count(check["boundary_loops"], "hole"), check["largest_hole_edges"]))
    else:
        found.append("closed")
    for key, what in (("nonmanifold_edges", "non-manifold edge"), ("nonmanifold_vertices", "non-manifold vertex"),
                      ("nonorientable_shells", "non-orientable shell")):
        if check[key]:
            found.append(count(check[key], what, what.replace("vertex", "vertices") if "vertex" in what else None))
    pairs = check["self_intersecting_pairs"]
    if pairs >= 0:
        found.append("%s%s" % ("at least " if check["self_intersections_capped"] else "",
                               count(pairs, "self-intersecting triangle pair")))
    repaired = []
    for key, what in (("flipped_faces_repaired", "triangle turned over"), ("degenerate_removed", "degenerate triangle set aside"),
                      ("duplicate_removed", "duplicate triangle merged")):
        if check[key]:
            repaired.append(count(check[key], what, what.replace("triangle", "triangles", 1)))
    return "Mesh: %s; repaired: %s" % (", ".join(found), ", ".join(repaired) or "nothing needed")


def patch_colors(labels, transition=None):
    """(M, 3) RGB in 0..1: one distinct pastel colour per patch id, red on transitions.

    Deterministic: a patch's colour depends only on its id. Golden-ratio hue steps keep
    neighbouring ids apart; hues near red are skipped so patches never look like transitions.
    """
    labels = np.asarray(labels)
    ids = np.unique(labels[labels >= 0])
    palette = np.array([colorsys.hsv_to_rgb(0.08 + 0.84 * ((0.3 + 0.618034 * i) % 1.0), 0.45, 0.95)
                        for i in ids]).reshape(-1, 3)
    colors = np.tile(np.asarray(TRANSITION_COLOR, dtype=np.float64), (len(labels), 1))
    patched = labels >= 0
    colors[patched] = palette[np.searchsorted(ids, labels[patched])]
    if transition is not None:
        colors[np.asarray(transition, dtype=bool)] = TRANSITION_COLOR
    return colors


def _colored_copy(doc, source_obj, suffix, colors, description):
    """A Mesh::Feature "<Label><suffix>": a copy of source_obj's mesh with per-facet colours."""
    kernel = source_obj.Mesh.copy()
    if len(colors) != kernel.CountFacets:
        raise MeshError("%d facet colours for %s, which has %d facets"
                        % (len(colors), source_obj.Label, kernel.CountFacets))
    obj = doc.addObject("Mesh::Feature", source_obj.Name + suffix)
    obj.Label = source_obj.Label + suffix
    obj.Mesh = kernel
    obj.Placement = source_obj.Placement
    obj.addProperty("App::PropertyColorList", FACE_COLORS, "Idealize", description)
    setattr(obj, FACE_COLORS, [tuple(c) for c in np.asarray(colors).tolist()])
    return obj


def make_segmented_mesh(doc, source_obj, segmentation=None):
    """Add a Mesh::Feature "<Label>_Segmented" to doc: a copy of source_obj's mesh with a
    per-facet colour property (FaceColors) by patch. source_obj is not modified.

    Segments source_obj first unless a segmentation of it is given. Callers wrap this in a
    document transaction so that one undo removes the result.
    """
    if segmentation is None:
        segmentation = segment_mesh_object(source_obj)
    return _colored_copy(doc, source_obj, "_Segmented", patch_colors(segmentation.labels, segmentation.transition),
                         "Colour of each facet: one per feature patch, red on transitions")
