"""The feature layer as a FreeCAD document object, without any GUI (Draft's "objects" layer).

A ``Mesh::FeaturePython`` linked to its source mesh (which stays untouched). Its Mesh is the
idealized mesh (the source's triangles, vertices moved onto their features); everything the layer
knows lives in properties, so undo, redo, save and reopen keep it: Labels (feature per triangle),
FeatureTable (JSON: features, adjacency, relations, deviation, tolerance), VertexDeviation and the
per-facet FaceColors the view shows. Labels is saved compactly (zlib-compressed binary, base64 in
LabelsData, instead of one XML element per triangle: FreeCAD saves an integer list so, a float
list as a binary file) and rebuilt when the document is reopened. It recomputes when the source mesh or its options change;
a recompute with nothing changed costs one fingerprint of the source.

Console use (also in freecadcmd)::

    import idealize
    layer = idealize.make_feature_layer(App.ActiveDocument.Mesh)
    solid = idealize.make_solid(layer)
"""
import base64
import hashlib
import json
import os
import zlib

import numpy as np

from ..features import DEFAULTS, FeatureLayer, idealize
from .mesh import FACE_COLORS, deviation_colors, mesh_from_freecad, patch_colors, type_colors, usable_mesh
from ..mesh import MeshError

PARAMETER_PATH = "User parameter:BaseApp/Preferences/Mod/Idealize"
COLOR_MODES = ["Type", "Feature", "Deviation"]
# Options of the layer: (property, type, preference key, default, description). Defaults are the
# native core's (feature_layer.h); the preferences page writes the preference keys.
OPTIONS = [
    ("AngleTolerance", "App::PropertyAngle", "AngleTolerance", DEFAULTS["angle_tolerance_degrees"],
     "Directions closer than this are parallel or perpendicular; axes within it of the part's ideal "
     "directions (0/10/30/45/60 deg) snap to them"),
    ("DistanceTolerance", "App::PropertyDistance", "DistanceTolerance", DEFAULTS["distance_tolerance"],
     "Axes, centres, radii and offsets closer than this are equal; 0: 0.1 % of the bounding-box diagonal"),
    ("RadiusTolerance", "App::PropertyPercent", "RadiusTolerancePercent", round(100 * DEFAULTS["radius_tolerance"]),
     "Radii within this percentage of each other are one design radius"),
    ("IdealizeRelations", "App::PropertyBool", "IdealizeRelations", DEFAULTS["idealize"],
     "Make parallel, coaxial, equal-radius ... relations exact and snap axes to ideal directions"),
]
# Property attribute flags (App::PropertyType): Output properties do not touch the object, so
# results and colours can be set without triggering a recompute.
_READ_ONLY, _OUTPUT = 1, 8


def preferences():
    """The option defaults from FreeCAD's parameters (the preferences page), as {property: value}."""
    import FreeCAD
    params = FreeCAD.ParamGet(PARAMETER_PATH)
    values = {}
    for name, kind, key, default, _ in OPTIONS:
        if kind == "App::PropertyBool":
            values[name] = params.GetBool(key, default)
        elif kind == "App::PropertyPercent":
            values[name] = params.GetInt(key, default)
        else:
            values[name] = params.GetFloat(key, default)
    return values


def layer_options(values):
    """The keyword arguments of :func:`idealize.idealize` from option values ({property: value},
    as :func:`preferences` gives them)."""
    distance = float(values["DistanceTolerance"])
    return {"angle_tolerance": float(values["AngleTolerance"]),
            "distance_tolerance": distance if distance > 0 else None,
            "radius_tolerance": values["RadiusTolerance"] / 100.0,
            "idealize_relations": bool(values["IdealizeRelations"]),
            "self_intersections": True}  # the task panel shows the whole mesh check


def object_options(obj):
    """:func:`layer_options` of a layer object's option properties."""
    return layer_options({name: getattr(obj, name) for name, *_ in OPTIONS})


def fingerprint(mesh, options, edits=()):
    """Identifies the input of a layer: the source's vertices and triangles, the options and the
    edits applied after idealization (a layer without edits keeps the fingerprint it always had)."""
    digest = hashlib.sha1(np.ascontiguousarray(mesh.vertices).tobytes())
    digest.update(np.ascontiguousarray(mesh.faces).tobytes())
    digest.update(json.dumps(options, sort_keys=True).encode())
    if edits:
        digest.update(json.dumps(list(edits), sort_keys=True).encode())
    return digest.hexdigest()


def object_edits(obj):
    """The edits a layer object applies after idealization (its Edits property, JSON), in order."""
    text = getattr(obj, "Edits", "") or ""
    return json.loads(text) if text else []


def source_mesh(obj):
    """The :class:`idealize.Mesh` of the layer's source (global coordinates)."""
    if obj.Source is None:
        raise MeshError("the feature layer %s has no source mesh" % obj.Label)
    return usable_mesh(obj.Source)


def ply_bytes(vertices, faces):
    """A binary PLY of exactly these vertices and triangles (single-precision coordinates)."""
    faces = np.asarray(faces)
    header = ("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
              "property float z\nelement face %d\nproperty list uchar int vertex_indices\nend_header\n"
              % (len(vertices), len(faces))).encode("ascii")
    records = np.empty(len(faces), dtype=[("n", "u1"), ("v", "<i4", (3,))])
    records["n"], records["v"] = 3, faces
    return header + np.asarray(vertices, dtype="<f4").tobytes() + records.tobytes()


def mesh_from_ply(data):
    """A Mesh.Mesh read from PLY bytes. FreeCAD's PLY reader keeps vertices and triangles as they
    are, in order (no welding, no dropped facets), so facet i is triangle i; it is ~7x faster than
    adding the facets from Python lists."""
    import tempfile
    import Mesh
    handle, path = tempfile.mkstemp(suffix=".ply", prefix="idealize-")
    try:
        with os.fdopen(handle, "wb") as f:
            f.write(data)
        return Mesh.Mesh(path)
    finally:
        os.remove(path)


def freecad_mesh(vertices, faces):
    """A Mesh.Mesh with exactly these vertices and triangles, in this order."""
    return mesh_from_ply(ply_bytes(vertices, faces))


def _jsonable(value):
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def deviation_scale(vertex_deviation, distance_tolerance):
    """Top of the deviation colour scale: the 99.5th percentile of the vertex deviations (a few
    outliers would otherwise paint everything else blue), at least the distance tolerance / 100."""
    deviation = np.asarray(vertex_deviation, dtype=np.float64)
    deviation = deviation[np.isfinite(deviation)]
    return max(float(np.percentile(deviation, 99.5)) if len(deviation) else 0.0, 0.01 * distance_tolerance)


def layer_colors(mode, features, labels, faces, vertex_deviation, distance_tolerance, highlight=None):
    """(M, 3) RGB of a layer's facets in colour mode `mode` (COLOR_MODES), with every feature but
    `highlight` (a feature id, or a list of them) dimmed when given."""
    labels = np.asarray(labels, dtype=np.int64)
    if mode == "Feature":
        colors = patch_colors(labels)
    elif mode == "Deviation":
        # A facet shows its worst vertex (NaN, grey, only where no vertex has an analytic surface).
        per_facet = np.asarray(vertex_deviation, dtype=np.float64)[np.asarray(faces, dtype=np.int64)]
        worst = np.where(np.isnan(per_facet), -np.inf, per_facet).max(axis=1)
        colors = deviation_colors(np.where(np.isfinite(worst), worst, np.nan),
                                  deviation_scale(vertex_deviation, distance_tolerance))
    else:
        colors = type_colors(features, labels)
    if highlight is not None:
        others = ~np.isin(labels, np.atleast_1d(np.asarray(highlight, dtype=np.int64)))
        colors[others] = 0.35 * colors[others] + 0.65 * 0.85
    return colors


def color_tuples(colors):
    return [tuple(c) for c in np.asarray(colors).tolist()]


def set_colors(obj, mode, highlight=None):
    """Paint the layer's facets (the FaceColors property the mesh view shows)."""
    table = json.loads(obj.FeatureTable)
    faces = mesh_from_freecad(obj.Mesh).faces if mode == "Deviation" else None
    colors = layer_colors(mode, table["features"], obj.Labels, faces, obj.VertexDeviation, table["distance_tolerance"],
                          highlight)
    setattr(obj, FACE_COLORS, color_tuples(colors))


class LayerRecord:
    """What a layer object stores of a computed :class:`idealize.FeatureLayer`, made ready without
    touching the document: a GUI builds it in its worker thread, so that storing it (`store`) is
    quick in the GUI thread."""

    def __init__(self, layer, options, mode="Type", edits=(), source=None):
        """`edits`: those applied to the idealized layer to give `layer` (idealize.edit.apply);
        `source`: the source mesh, when `layer` is edited (its mesh is then the edited one)."""
        self.layer = layer
        self.edits = list(edits)
        # The triangles with the mesh check's orientation repair: the B-rep is built on them.
        self.mesh_data = ply_bytes(layer.idealized_vertices, layer.oriented_faces)
        self.labels = np.asarray(layer.labels, dtype=np.int64).tolist()
        self.labels_data = packed(layer.labels, "<i4")
        self.table = json.dumps(_jsonable({
            "features": layer.features, "adjacency": layer.adjacency, "relations": layer.relations,
            "deviation": layer.deviation, "distance_tolerance": layer.distance_tolerance,
            "form_deviation": layer.form_deviation, "mesh_kind": layer.mesh_kind, "noise": layer.noise,
            "angle_tolerance_degrees": layer.angle_tolerance,
            "normal_noise": layer.normal_noise, "mesh_check": layer.mesh_check,
            "edited": bool(self.edits), "edge_lengths": layer.edge_lengths}))
        self.vertex_deviation = np.asarray(layer.vertex_deviation, dtype=np.float64).tolist()
        self.fingerprint = fingerprint(source if source is not None else layer.mesh, options, self.edits)
        self.mode = mode
        self.colors = color_tuples(layer_colors(mode, layer.features, layer.labels, layer.mesh.faces,
                                                layer.vertex_deviation, layer.distance_tolerance))

    def store(self, obj):
        layer = self.layer
        obj.Mesh = mesh_from_ply(self.mesh_data)
        obj.Labels = self.labels
        obj.LabelsData = self.labels_data
        obj.FeatureTable = self.table
        obj.VertexDeviation = self.vertex_deviation
        obj.Features = len(layer.features)
        obj.MaxDeviation = float(layer.deviation["max"])
        obj.RmsDeviation = float(layer.deviation["rms"])
        obj.SourceFingerprint = self.fingerprint
        edits = json.dumps(self.edits) if self.edits else ""
        if getattr(obj, "Edits", "") != edits:
            obj.Edits = edits
        if color_mode(obj) == self.mode:
            setattr(obj, FACE_COLORS, self.colors)
        else:
            set_colors(obj, color_mode(obj))


def layer_record(mesh, options, mode="Type", progress=None, edits=()):
    """The :class:`LayerRecord` of :func:`idealize.idealize` of `mesh` with `options`
    (:func:`layer_options`) and then `edits` (:func:`idealize.edit.apply`), colours in `mode`: all of
    a layer's work that needs no document, so a GUI runs it in a worker thread."""
    layer = idealize(mesh, progress=progress, **options)
    if edits:
        from .. import edit
        layer = edit.apply(layer, edits)
    if progress is not None:
        progress.report("preparing the document", 1.0)
    return LayerRecord(layer, options, mode, edits, source=mesh)


def _run_here(obj, function, *args, **kwargs):
    return function(*args, **kwargs)


# How a layer object runs its recompute: runner(obj, function, *args, **kwargs) returns
# function(*args, progress=..., **kwargs), or None when the user cancelled it (the layer then keeps
# its previous result). Without a GUI it runs in the calling thread with no progress and cannot be
# cancelled; idealize.gui.view_layer sets one that runs it in a worker thread behind the progress
# dialog with Cancel, as the commands do (this module imports nothing of the GUI).
_runner = _run_here


def set_runner(runner):
    """Route the layers' recomputes through `runner` (None: back to the calling thread)."""
    global _runner
    _runner = runner or _run_here


class _SourceWatcher:
    """Touches the feature layers of a mesh whose Mesh or Placement changed. A Mesh::Feature's
    Mesh is an output property: FreeCAD itself would not recompute the objects that use it."""

    def slotChangedObject(self, obj, prop):
        if prop not in ("Mesh", "Placement") or obj.Document.Restoring:
            return
        for user in obj.InList:
            if is_feature_layer(user) and user.Source == obj:
                user.touch()


_watcher = None


def _watch_sources():
    global _watcher
    if _watcher is None:
        import FreeCAD
        _watcher = _SourceWatcher()
        FreeCAD.addDocumentObserver(_watcher)


class FeatureLayerObject:
    """Proxy of the feature layer document object."""

    Type = "IdealizeFeatureLayer"  # what is_feature_layer() asks: a class attribute, not saved

    def __init__(self, obj, source):
        obj.Proxy = self
        obj.addProperty("App::PropertyLink", "Source", "Idealize", "The mesh the layer was made from (never modified)")
        obj.Source = source
        defaults = preferences()
        for name, kind, _, _, description in OPTIONS:
            obj.addProperty(kind, name, "Options", description)
            setattr(obj, name, defaults[name])
        results = [("App::PropertyIntegerList", "Labels", "The feature of every triangle of the source, in its order"),
                   ("App::PropertyString", "FeatureTable",
                    "JSON: features (type, params, rms ...), adjacency, relations, deviation, tolerance"),
                   ("App::PropertyFloatList", "VertexDeviation",
                    "Distance of every source vertex from the surfaces of its features"),
                   ("App::PropertyInteger", "Features", "Number of features"),
                   ("App::PropertyDistance", "MaxDeviation", "Largest distance of a source vertex from its features"),
                   ("App::PropertyDistance", "RmsDeviation", "RMS distance of the source vertices from their features"),
                   ("App::PropertyString", "SourceFingerprint", "Identifies the source mesh and options the layer was made from"),
                   ("App::PropertyColorList", FACE_COLORS, "Colour of every facet (see the view's ColorBy)")]
        for kind, name, description in results:
            obj.addProperty(kind, name, "Layer", description, _READ_ONLY | _OUTPUT)
        _compact_storage(obj)
        _add_edits_property(obj)
        obj.setEditorMode("SourceFingerprint", 2)  # hidden: bookkeeping only
        obj.setEditorMode("Labels", 2)  # hidden: a long list the property editor would choke on
        obj.setEditorMode("VertexDeviation", 2)
        obj.setEditorMode("FeatureTable", 2)
        obj.setEditorMode(FACE_COLORS, 2)
        _watch_sources()

    def feature_layer(self, obj):
        """The :class:`idealize.FeatureLayer` the object holds: what idealize.make_solid and the
        other core functions take a layer object for (they import nothing of FreeCAD)."""
        return feature_layer(obj)

    def execute(self, obj):
        """Recompute the layer when its source or options changed, through the runner (in the GUI:
        a worker thread behind the progress dialog, whose Cancel leaves the layer as it was)."""
        mesh = source_mesh(obj)
        options = object_options(obj)
        edits = object_edits(obj)
        if obj.SourceFingerprint != fingerprint(mesh, options, edits):
            record = _runner(obj, layer_record, mesh, options, color_mode(obj), edits=edits)
            if record is not None:  # None: cancelled; its fingerprint still tells it is out of date
                record.store(obj)

    def onDocumentRestored(self, obj):
        restore_compact(obj)
        _add_edits_property(obj)  # a layer saved before editing existed
        _watch_sources()

    # All state is in properties. FreeCAD 0.20 saves a proxy with __getstate__ when it has one,
    # and Python 3.11 gives every object a default one (its __dict__): defined here, it is ours.
    def __getstate__(self):
        return None

    def __setstate__(self, state):
        return None

    def dumps(self):  # FreeCAD before 0.20 / Python before 3.11 ask these instead
        return None

    def loads(self, state):
        return None


# The lists saved compactly: (list property, its packed copy, dtype).
_PACKED = (("Labels", "LabelsData", "<i4"),)


def packed(values, dtype):
    """`values` as zlib-compressed little-endian `dtype` bytes in base64: what a document saves."""
    return base64.b64encode(zlib.compress(np.ascontiguousarray(values, dtype=dtype).tobytes(), 6)).decode("ascii")


def unpacked(text, dtype):
    """The array `packed` wrote."""
    return np.frombuffer(zlib.decompress(base64.b64decode(text)), dtype=dtype)


def _compact_storage(obj):
    """The packed copy of Labels (hidden) is what the document saves; the list is transient."""
    for name, data, _ in _PACKED:
        if not hasattr(obj, data):
            obj.addProperty("App::PropertyString", data, "Layer", "%s, packed for saving" % name, _READ_ONLY | _OUTPUT)
        obj.setEditorMode(data, 2)
        obj.setPropertyStatus(name, "Transient")


def restore_compact(obj):
    """Rebuilds Labels from its packed copy after the document was read; a layer saved by a version
    that stored the list keeps it, and is packed from now on."""
    stored_as_list = {name: not getattr(obj, data, "") for name, data, _ in _PACKED}
    _compact_storage(obj)
    for name, data, dtype in _PACKED:
        if not stored_as_list[name]:
            setattr(obj, name, unpacked(getattr(obj, data), dtype).tolist())
        elif hasattr(obj, name):
            setattr(obj, data, packed(getattr(obj, name), dtype))


def color_mode(obj):
    """The view's colour mode, "Type" without a GUI."""
    view = getattr(obj, "ViewObject", None)
    return getattr(view, "ColorBy", "Type") if view is not None else "Type"


def apply_layer(obj, layer, options):
    """Store a computed :class:`idealize.FeatureLayer` in the object: idealized mesh, labels,
    table, deviation and colours."""
    LayerRecord(layer, options, color_mode(obj)).store(obj)


def is_feature_layer(obj):
    proxy = getattr(obj, "Proxy", None)
    return getattr(proxy, "Type", None) == "IdealizeFeatureLayer"


def feature_layer(obj):
    """The :class:`idealize.FeatureLayer` a layer object holds (source mesh + stored results; an
    edited layer's mesh is its own)."""
    if not is_feature_layer(obj):
        raise TypeError("%s is not an Idealize feature layer" % getattr(obj, "Label", obj))
    table = json.loads(obj.FeatureTable)
    idealized = mesh_from_freecad(obj.Mesh)
    mesh = idealized if table.get("edited") else source_mesh(obj)
    labels = np.asarray(obj.Labels, dtype=np.int32)
    if len(labels) != mesh.n_triangles:
        raise MeshError("the feature layer %s is out of date: its source mesh changed; recompute it" % obj.Label)
    layer = FeatureLayer(mesh, None, {
        "labels": labels, "features": table["features"], "adjacency": table["adjacency"],
        "relations": table["relations"], "idealized_vertices": idealized.vertices,
        "vertex_deviation": np.asarray(obj.VertexDeviation, dtype=np.float64),
        "max_deviation": table["deviation"]["max"], "rms_deviation": table["deviation"]["rms"],
        "distance_tolerance": table["distance_tolerance"], "form_deviation": table.get("form_deviation"),
        "mesh_kind": table.get("mesh_kind"), "noise": table.get("noise"),
        "angle_tolerance_degrees": table.get("angle_tolerance_degrees"), "normal_noise": table.get("normal_noise"),
        "timings": []})
    layer.mesh_check = table.get("mesh_check")
    layer.oriented_faces = idealized.faces  # stored with the orientation repair
    layer.edge_lengths = table.get("edge_lengths")
    return layer


def _add_edits_property(obj):
    if not hasattr(obj, "Edits"):
        obj.addProperty("App::PropertyString", "Edits", "Layer",
                        "JSON: the edits applied after idealization, in order (push/pull, parameters, moves)",
                        _READ_ONLY | _OUTPUT)
        obj.setEditorMode("Edits", 2)


def add_edit(obj, step, edited=None):
    """Apply one edit (a dict, see :func:`idealize.edit.apply`) to a layer object: the object stores
    the edited layer and the edit joins its Edits, so that a recompute (its source or options
    changed) replays it. Returns the edited :class:`idealize.FeatureLayer`. Raises
    idealize.edit.EditConflict (the object unchanged) when no ideal configuration satisfies it.
    `edited`: the edit's result already computed from the object's layer as it is now (by a worker
    thread), stored as is: the edited :class:`idealize.FeatureLayer`, or its :class:`LayerRecord`
    (:func:`edit_record`). Callers in the GUI wrap this in a transaction."""
    from .. import edit
    if isinstance(edited, LayerRecord):
        edited.store(obj)
        return edited.layer
    layer = edited if edited is not None else edit.apply(feature_layer(obj), [step])
    LayerRecord(layer, object_options(obj), color_mode(obj), object_edits(obj) + [dict(step)],
                source=source_mesh(obj)).store(obj)
    return layer


def edit_inputs(obj, layer=None, source=None):
    """What :func:`edit_record` needs of a layer object, read in the GUI thread: (its layer, options,
    colour mode, edits so far, source mesh). `layer` and `source`: the object's layer and source mesh
    when the caller has them already (a panel that keeps them between edits)."""
    return (layer if layer is not None else feature_layer(obj), object_options(obj), color_mode(obj),
            object_edits(obj), source if source is not None else source_mesh(obj))


def edit_record(inputs, step):
    """The :class:`LayerRecord` of `step` applied to a layer object whose :func:`edit_inputs` are
    `inputs`: all of add_edit's work that needs no document, for a worker thread."""
    from .. import edit
    layer, options, mode, edits, source = inputs
    return LayerRecord(edit.apply(layer, [step]), options, mode, list(edits) + [dict(step)], source=source)


def make_feature_layer(source, layer=None, doc=None):
    """Add a feature layer object "<Label>_Layer" for a Mesh::Feature `source` to its document
    (or `doc`). With a precomputed `layer` (:class:`idealize.FeatureLayer` or :class:`LayerRecord`
    of this source with the preferences' options), it is stored as is; otherwise the layer is
    computed. Returns the object.

    The source is not modified. Callers in the GUI wrap this in a transaction.
    """
    import FreeCAD
    if not hasattr(source, "isDerivedFrom") or not source.isDerivedFrom("Mesh::Feature"):
        raise TypeError("make_feature_layer() takes a mesh object (Mesh::Feature), got %s"
                        % getattr(source, "TypeId", type(source).__name__))
    doc = doc or source.Document
    obj = doc.addObject("Mesh::FeaturePython", source.Name + "_Layer")
    obj.Label = source.Label + "_Layer"
    FeatureLayerObject(obj, source)
    if FreeCAD.GuiUp:
        from ..gui.view_layer import ViewProviderFeatureLayer
        ViewProviderFeatureLayer(obj.ViewObject)
    options = object_options(obj)
    if isinstance(layer, LayerRecord):
        layer.store(obj)
    else:
        apply_layer(obj, layer if layer is not None else idealize(source_mesh(obj), **options), options)
    obj.purgeTouched()  # up to date: nothing for a recompute to do
    return obj
