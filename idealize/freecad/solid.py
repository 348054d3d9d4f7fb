"""Fitted solids and Part primitives in a FreeCAD document, without any GUI.

Works in freecadcmd and in the GUI; the GUI commands (idealize.gui) add undo and display.
"""
import numpy as np

from .._loader import native
from ..brep import make_solid
from .mesh import SURFACE_COLORS, idealize_mesh_object

# Surface type of a Part face -> the type names of the feature layer.
PART_SURFACE_TYPES = {"Plane": "plane", "Cylinder": "cylinder", "Cone": "cone", "Sphere": "sphere",
                      "Toroid": "torus", "BSplineSurface": "freeform"}


def solid_of_mesh_object(obj, layer=None):
    """(:class:`idealize.FeatureLayer`, :class:`idealize.Solid`) of a Mesh::Feature or Mesh.Mesh."""
    if layer is None:
        layer = idealize_mesh_object(obj)
    return layer, make_solid(layer)


def _vector(values):
    import FreeCAD
    return FreeCAD.Vector(*[float(v) for v in values])


def _frame(axis):
    axis = np.asarray(axis, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    x = np.cross(axis, helper)
    x /= np.linalg.norm(x)
    return axis, x, np.cross(axis, x)


def bspline_surface(points, normals=None, weights=None):
    """The Part.BSplineSurface fitted to a freeform patch: `points` (n, 3) as a height field over
    their mean plane (a bicubic B-spline, reaching a little beyond them); `normals` (m, 3, e.g. its
    face normals) check that the patch is one, `weights` (n,) default to 1. Raises ValueError with
    the reason when it is not, or for fewer than 16 points."""
    import FreeCAD  # noqa: F401  (FreeCAD before Part)
    import Part
    points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    normals = np.ascontiguousarray(np.zeros((0, 3)) if normals is None else normals, dtype=np.float64).reshape(-1, 3)
    weights = np.ones(len(points)) if weights is None else np.ascontiguousarray(weights, dtype=np.float64).reshape(-1)
    if len(weights) != len(points):
        raise ValueError("weights must have one value per point")
    if not (np.all(np.isfinite(points)) and np.all(np.isfinite(normals)) and np.all(weights >= 0)):
        raise ValueError("points and normals must be finite, weights non-negative")
    fit = native.fit_bspline_surface(points, normals, weights)
    if not fit["valid"]:
        raise ValueError(fit["problem"])
    degree, poles = fit["degree"], fit["poles"]
    ends = lambda knots: [degree + 1] + [1] * (len(knots) - 2) + [degree + 1]  # noqa: E731
    surface = Part.BSplineSurface()
    surface.buildFromPolesMultsKnots([[_vector(p) for p in row] for row in poles], ends(fit["knots_u"]),
                                     ends(fit["knots_v"]), [float(k) for k in fit["knots_u"]],
                                     [float(k) for k in fit["knots_v"]], False, False, degree, degree)
    return surface


def primitive_shape(feature, points, normals=None):
    """A Part shape for one feature, sized to cover its patch's `points` (n, 3): a plane face
    over the patch's extent, a cylinder or cone between its extreme heights along the axis, a
    whole sphere or torus, the B-spline face fitted to a freeform patch (`normals`: its face
    normals, which tell whether it is a height field). None for a freeform patch that no B-spline
    surface fits."""
    import FreeCAD  # noqa: F401  (FreeCAD before Part)
    import Part
    kind, p = feature["type"], feature["params"]
    if kind == "freeform":
        try:
            return bspline_surface(points, normals).toShape()
        except ValueError:
            return None
    if kind == "plane":
        normal, x, y = _frame(p["normal"])
        origin = np.asarray(p["point"], dtype=np.float64)
        u, v = (points - origin) @ x, (points - origin) @ y
        corner = origin + u.min() * x + v.min() * y
        return Part.makePlane(float(np.ptp(u)) or 1e-6, float(np.ptp(v)) or 1e-6, _vector(corner), _vector(normal),
                              _vector(x))
    if kind in ("cylinder", "cone"):
        axis = _frame(p["axis"])[0]
        origin = np.asarray(p["point"] if kind == "cylinder" else p["apex"], dtype=np.float64)
        h = (points - origin) @ axis
        low, high = float(h.min()), float(h.max())
        base = _vector(origin + low * axis)
        if kind == "cylinder":
            return Part.makeCylinder(float(p["radius"]), max(high - low, 1e-6), base, _vector(axis))
        t = np.tan(float(p["half_angle"]))
        return Part.makeCone(max(low, 0.0) * t, max(high, 0.0) * t, max(high - low, 1e-6), base, _vector(axis))
    if kind == "sphere":
        return Part.makeSphere(float(p["radius"]), _vector(p["center"]))
    if kind == "torus":  # a lemon (major < 0) lies on the spindle torus of radii |major|, minor
        return Part.makeTorus(abs(float(p["major"])), float(p["minor"]), _vector(p["center"]), _vector(p["axis"]))
    return None


def make_primitives(doc, source_obj, layer):
    """Add an App::DocumentObjectGroup "<Label>_Primitives" holding one Part::Feature per
    feature (named "F<id>_<type>"), placed and sized by the idealized parameters (a freeform
    feature's is its fitted B-spline face, when one fits)."""
    group = doc.addObject("App::DocumentObjectGroup", source_obj.Name + "_Primitives")
    group.Label = source_obj.Label + "_Primitives"
    _add_primitives(doc, group, layer)
    return group


def refill_primitives(group, layer):
    """Replace the primitives of a group :func:`make_primitives` made by those of `layer` (an
    edited layer's); they stay hidden, as the solid's commands leave them."""
    doc = group.Document
    for obj in list(group.Group):
        doc.removeObject(obj.Name)
    _add_primitives(doc, group, layer)
    for obj in group.Group:
        if getattr(obj, "ViewObject", None) is not None:
            obj.ViewObject.Visibility = False


def _add_primitives(doc, group, layer):
    mesh = layer.mesh
    labels = np.asarray(layer.labels)
    for feature in layer.features:
        faces = mesh.faces[labels == feature["id"]]
        if not len(faces):
            continue
        corners = mesh.vertices[faces]
        normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        normals /= np.maximum(np.linalg.norm(normals, axis=1), 1e-300)[:, None]
        shape = primitive_shape(feature, mesh.vertices[np.unique(faces)], normals)
        if shape is None:
            continue
        obj = doc.addObject("Part::Feature", "F%d_%s" % (feature["id"], feature["type"]))
        obj.Shape = shape
        group.addObject(obj)


def make_solid_object(doc, source_obj, layer=None, solid=None, with_primitives=True):
    """Add a Part::Feature "<Label>_Solid" with the fitted B-rep of source_obj (a Mesh::Feature)
    and, with_primitives, a group of Part primitives. source_obj is not modified. The feature
    layer and the :class:`idealize.Solid` are computed unless given.

    Returns (solid object, primitives group or None, :class:`idealize.Solid`). The shape is a
    valid solid, or, when the faces do not close, the faces that could be made (the object's
    IdealizeProblems property lists why). Callers wrap this in a document transaction.
    """
    if solid is None:
        layer, solid = solid_of_mesh_object(source_obj, layer)
    obj = doc.addObject("Part::Feature", source_obj.Name + "_Solid")
    obj.Label = source_obj.Label + "_Solid"
    set_solid(obj, solid)
    group = make_primitives(doc, source_obj, layer) if with_primitives else None
    return obj, group, solid


def set_solid(obj, solid):
    """Give a solid object (a Part::Feature) the :class:`idealize.Solid`: its shape, whether it is a
    valid closed solid, what failed, and the feature of each face (so that a click on a face of the
    solid is a click on that feature of the layer)."""
    for kind, name, doc in (("App::PropertyBool", "IdealizeSolid", "True: a valid closed solid"),
                            ("App::PropertyStringList", "IdealizeProblems", "What failed, per feature"),
                            ("App::PropertyIntegerList", "IdealizeFaceFeatures",
                             "The feature of each face (Face1 first), -1 where none")):
        if not hasattr(obj, name):
            obj.addProperty(kind, name, "Idealize", doc)
    obj.setEditorMode("IdealizeFaceFeatures", 2)  # hidden: a list for the editing commands
    obj.Shape = solid.part_shape()
    obj.IdealizeSolid = bool(solid.solid)
    obj.IdealizeProblems = [("feature %d: " % f if f >= 0 else "") + m for f, m in solid.problems]
    obj.IdealizeFaceFeatures = [int(f) for f in solid.face_features]


def face_colors(shape):
    """Per-face RGB of a Part shape in the thesis colours of its surface types."""
    return [SURFACE_COLORS.get(PART_SURFACE_TYPES.get(type(face.Surface).__name__, "freeform"))
            for face in shape.Faces]


def export_step(objects, path):
    """Write the shapes of Part objects to a STEP file (FreeCAD's exporter, with colours)."""
    import FreeCAD  # noqa: F401
    import Import
    if not objects:
        raise ValueError("nothing to export")
    Import.export(list(objects), str(path))
