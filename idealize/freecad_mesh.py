"""FreeCAD document side of Idealize, without any GUI.

Importable without FreeCAD installed: FreeCAD modules are imported inside the functions. Works in
freecadcmd as well as in the GUI; the GUI commands (idealize.gui) only add display and undo.
"""
import colorsys
import itertools

import numpy as np

from .mesh import Mesh, MeshError
from .segmentation import segment

# Thesis colour code for fitted surface types, for when patches get one; RGB in 0..1.
SURFACE_COLORS = {
    "plane": (0.56, 0.93, 0.56),     # light green
    "cylinder": (1.0, 1.0, 0.0),     # yellow
    "cone": (0.68, 0.85, 0.90),      # light blue
    "sphere": (0.0, 0.39, 0.0),      # dark green
    "torus": (0.55, 0.0, 0.0),       # dark red
}
TRANSITION_COLOR = (1.0, 0.0, 0.0)   # edges / transition triangles: red

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


def segment_mesh_object(obj):
    """Segment a Mesh::Feature (or Mesh.Mesh); labels follow its facet order."""
    mesh = mesh_from_freecad(obj)
    if mesh.n_triangles == 0:
        raise MeshError("%s has no triangles" % (mesh.source or "the mesh"))
    return segment(mesh)


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


def make_segmented_mesh(doc, source_obj, segmentation=None):
    """Add a Mesh::Feature "<Label>_Segmented" to doc: a copy of source_obj's mesh with a
    per-facet colour property (FaceColors) by patch. source_obj is not modified.

    Segments source_obj first unless a segmentation of it is given. Callers wrap this in a
    document transaction so that one undo removes the result.
    """
    if segmentation is None:
        segmentation = segment_mesh_object(source_obj)
    kernel = source_obj.Mesh.copy()
    if len(segmentation.labels) != kernel.CountFacets:
        raise MeshError("the segmentation has %d labels but %s has %d facets"
                        % (len(segmentation.labels), source_obj.Label, kernel.CountFacets))
    obj = doc.addObject("Mesh::Feature", source_obj.Name + "_Segmented")
    obj.Label = source_obj.Label + "_Segmented"
    obj.Mesh = kernel
    obj.Placement = source_obj.Placement
    obj.addProperty("App::PropertyColorList", FACE_COLORS, "Idealize",
                    "Colour of each facet: one per feature patch, red on transitions")
    setattr(obj, FACE_COLORS, [tuple(c) for c in patch_colors(segmentation.labels, segmentation.transition).tolist()])
    return obj
