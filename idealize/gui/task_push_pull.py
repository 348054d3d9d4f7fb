"""Task panel of Push/Pull (Resources/ui/PushPull.ui): edits one feature of a feature layer, its
offset along its normal or one of its parameters, with the relations to keep. A preview of the
edited mesh replaces the layer in the 3D view as the value changes; a conflict shows in the panel.
An arrow on the picked point (a Coin3D dragger) pulls the face along its normal when dragged.
OK applies the edit as one undo step and regenerates the B-rep solids made from the layer's source.
"""
import math
import os

import FreeCAD
import FreeCADGui
import numpy as np

from .. import edit
from ..freecad import layer_object
from ..freecad import solid as freecad_solid
from ..brep import make_solid

UI_FILE = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                       "Resources", "ui", "PushPull.ui")
# What each type's parameters are called in the panel: (label, report name, shown as degrees).
PARAMETERS = {"cylinder": [("Radius", "radius", False), ("Hole depth (through past the far side)", "depth", False)],
              "sphere": [("Radius", "radius", False)],
              "torus": [("Major radius", "major", False), ("Minor radius", "minor", False)],
              "cone": [("Half angle", "half_angle", True)]}
# The preview waits for the typing to pause: a quarter second, about where a user notices a lag.
PREVIEW_DELAY_MS = 250


def edit_step(feature, parameter, value, keep):
    """The edit (a dict for idealize.edit.apply) the panel's values describe: "offset" pushes or
    pulls by `value`, "depth" gives a hole that depth, a parameter (its report name) takes `value`
    (degrees for a half angle)."""
    if parameter == "depth":
        return {"op": "set_depth", "hole_feature_id": int(feature["id"]), "depth": float(value)}
    if parameter == "offset":
        return {"op": "push_pull", "feature_id": int(feature["id"]), "distance": float(value), "keep": dict(keep)}
    if parameter == "half_angle":
        value = math.radians(value)
    return {"op": "set_parameter", "feature_id": int(feature["id"]), "name": parameter, "value": float(value),
            "keep": dict(keep)}


def solids_of(obj):
    """The B-rep solids made from the layer object's source: Part::Features with IdealizeSolid
    linked to it."""
    if obj.Source is None:
        return []
    return [other for other in obj.Document.Objects
            if hasattr(other, "IdealizeSolid") and getattr(other, "Source", None) == obj.Source]


def regenerate_solids(obj, layer, solid=None):
    """Rebuild the shape of every B-rep solid made from the layer's source (solids_of) from the
    edited `layer` (its :class:`idealize.Solid` when computed already), and its primitives. Returns
    how many."""
    count = 0
    if obj.Source is not None:
        group = obj.Document.getObject(obj.Source.Name + "_Primitives")
        if group is not None and group.isDerivedFrom("App::DocumentObjectGroup"):
            freecad_solid.refill_primitives(group, layer)
    for other in solids_of(obj):
        if solid is None:
            solid = make_solid(layer)
        freecad_solid.set_solid(other, solid)
        if other.ViewObject is not None:
            other.ViewObject.DiffuseColor = freecad_solid.face_colors(other.Shape)
        count += 1
    return count


def apply_in_one_step(obj, step, title, edited=None):
    """Add the edit `step` to the layer object as one undo step named `title`, regenerating the
    solids made from its source. `edited`: the step's result, computed already (see
    layer_object.add_edit). Otherwise the edit and the solids are computed first in a worker thread
    (a progress dialog with Cancel after half a second), and the document is changed only once they
    are: a refused or cancelled edit adds no undo step. Returns (the edited layer, solids
    regenerated), or None when it failed or was cancelled (the error reported)."""
    from .commands import report_error
    from .progress import run_with_progress
    from ..progress import Cancelled
    solid = None
    if edited is None:
        inputs = layer_object.edit_inputs(obj)
        with_solid = bool(solids_of(obj))

        def work(progress):
            record = layer_object.edit_record(inputs, step)
            return record, (make_solid(record.layer, progress=progress) if with_solid else None)
        try:
            edited, solid = run_with_progress(title, work)
        except Cancelled:
            FreeCADGui.getMainWindow().statusBar().showMessage("%s cancelled: the layer is unchanged" % title, 15000)
            return None
        except Exception as error:
            report_error(title, error)
            return None
    doc = obj.Document
    doc.openTransaction(title)
    try:
        layer = layer_object.add_edit(obj, step, edited)
        solids = regenerate_solids(obj, layer, solid)
        doc.recompute()
        doc.commitTransaction()
    except Exception as error:  # the document must not keep half an edit
        doc.abortTransaction()
        report_error(title, error)
        return None
    return layer, solids


class Preview:
    """The edited mesh drawn in the 3D view (coloured by feature type) in place of the layer."""

    def __init__(self, obj):
        from pivy import coin
        self.obj = obj
        self.node = coin.SoSeparator()
        hints = coin.SoShapeHints()
        hints.vertexOrdering = coin.SoShapeHints.COUNTERCLOCKWISE
        self.coordinates = coin.SoCoordinate3()
        self.groups = coin.SoGroup()  # a colour and the faces of that colour, per colour
        for child in (hints, self.coordinates, self.groups):
            self.node.addChild(child)
        self.view = FreeCADGui.getDocument(obj.Document.Name).ActiveView
        self.shown = False
        self.layer_visible = obj.ViewObject.Visibility
        self.solids_hidden = []

    def show(self, layer, highlight=None):
        """Draw `layer`, every feature but `highlight` (ids) dimmed when given."""
        colors = layer_object.layer_colors("Type", layer.features, layer.labels, layer.mesh.faces,
                                           layer.vertex_deviation, layer.distance_tolerance,
                                           highlight=list(highlight) if highlight else None)
        self.show_mesh(layer.mesh.vertices, layer.mesh.faces, colors)

    def show_mesh(self, V, F, colors):
        """Draw the mesh V (#V x 3), F (#F x 3) with a colour per face (#F x 3, 0..1): the faces of
        each colour as one shape of that colour (a handful of colours, where a colour per face took
        18 ms more to hand over on 100k triangles). The arrays go to Coin as numpy arrays (pivy takes
        them: about 30 ms for 100k triangles, where lists took 130)."""
        from pivy import coin
        self.coordinates.point.setValues(0, len(V), np.ascontiguousarray(V, dtype=np.float32))
        self.coordinates.point.setNum(len(V))
        # Colours as 8-bit RGB keys: those a user tells apart.
        rgb = np.clip(np.rint(np.asarray(colors, dtype=np.float64) * 255.0), 0, 255).astype(np.int64)
        keys = (rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2]
        order = np.argsort(keys, kind="stable")
        values, starts = np.unique(keys[order], return_index=True)
        self.groups.removeAllChildren()
        for key, begin, end in zip(values.tolist(), starts, list(starts[1:]) + [len(order)]):
            color, faces = coin.SoBaseColor(), coin.SoIndexedFaceSet()
            color.rgb.setValue(((key >> 16) & 255) / 255.0, ((key >> 8) & 255) / 255.0, (key & 255) / 255.0)
            mine = F[order[begin:end]]
            index = np.hstack([mine, -np.ones((len(mine), 1), dtype=mine.dtype)]).astype(np.int32).ravel()
            faces.coordIndex.setValues(0, len(index), index)
            group = coin.SoSeparator()
            group.addChild(color)
            group.addChild(faces)
            self.groups.addChild(group)
        if not self.shown:
            self.view.getSceneGraph().addChild(self.node)
            self.obj.ViewObject.Visibility = False
            # The solids made from the layer lie where the preview does: hidden while it shows.
            self.solids_hidden = [o for o in solids_of(self.obj) if o.ViewObject is not None and o.ViewObject.Visibility]
            for solid in self.solids_hidden:
                solid.ViewObject.Visibility = False
            self.shown = True

    def hide(self):
        if self.shown:
            self.view.getSceneGraph().removeChild(self.node)
            self.obj.ViewObject.Visibility = self.layer_visible
            for solid in self.solids_hidden:
                try:
                    solid.ViewObject.Visibility = True
                except (ReferenceError, RuntimeError):  # deleted meanwhile
                    pass
            self.shown = False


class NormalDragger:
    """A Coin3D arrow at the picked point along the face's outward normal: dragging it pulls the
    face (its offset, in mm, goes to `changed`); `show(distance)` puts it where a typed value is."""

    def __init__(self, view, point, normal, size, changed):
        from pivy import coin
        self.view, self.changed, self.size = view, changed, size
        self.node = coin.SoSeparator()
        transform = coin.SoTransform()
        transform.translation.setValue(*[float(x) for x in point])
        # The dragger moves along its local x axis: turn x onto the normal.
        transform.rotation.setValue(coin.SbRotation(coin.SbVec3f(1, 0, 0), coin.SbVec3f(*[float(x) for x in normal])))
        transform.scaleFactor.setValue(size, size, size)
        self.dragger = coin.SoTranslate1Dragger()
        self.node.addChild(transform)
        self.node.addChild(self.dragger)
        self.quiet = False
        self.placed = 0.0
        self.sensor = coin.SoFieldSensor(self._moved, None)
        self.sensor.attach(self.dragger.translation)
        view.getSceneGraph().addChild(self.node)

    def _moved(self, data, sensor):
        # The sensor fires later, from the event loop: a position that show() set is not a drag.
        distance = round(self.dragger.translation.getValue()[0] * self.size, 4)
        if not self.quiet and distance != self.placed:
            self.changed(distance)

    def show(self, distance):
        self.quiet = True
        self.placed = round(distance, 4)
        self.dragger.translation.setValue(distance / self.size, 0.0, 0.0)
        self.quiet = False

    def remove(self):
        self.sensor.detach()
        self.view.getSceneGraph().removeChild(self.node)


def picked_frame(layer, facet):
    """The centroid of a facet of the layer's mesh and its outward unit normal (the mesh's
    orientation, turned outward when the mesh faces in)."""
    V, F = layer.idealized_vertices, np.asarray(layer.oriented_faces)
    corners = V[F[facet]]
    normal = np.cross(corners[1] - corners[0], corners[2] - corners[0])
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    if np.einsum("ij,ij->i", a, np.cross(b, c)).sum() < 0:
        normal = -normal
    return corners.mean(axis=0), normal / max(np.linalg.norm(normal), 1e-300)


#: The panel open now (None when none is): for macros and tests.
active_panel = None


class PushPullPanel:
    def __init__(self, obj, feature_id, facet=None):
        from PySide import QtCore, QtGui
        self.obj = obj
        self.layer = layer_object.feature_layer(obj)
        self.feature = self.layer.features[feature_id]
        self.form = FreeCADGui.PySideUic.loadUi(UI_FILE)
        self.form.setWindowIcon(QtGui.QIcon(os.path.join(os.path.dirname(UI_FILE), "..", "icons",
                                                         "Idealize_PushPull.svg")))
        from .task_layer import key_parameters
        self.form.feature.setText("Feature %d, %s: %s." % (feature_id, self.feature["type"],
                                                           key_parameters(self.feature)))
        self.choices = [("Push/pull (offset)", "offset", False)] + PARAMETERS.get(self.feature["type"], [])
        self.form.parameter.addItems([label for label, _, _ in self.choices])
        self.form.parameter.currentIndexChanged.connect(self.parameter_changed)
        self.form.value.setRange(-1e9, 1e9)
        self.form.value.valueChanged.connect(self.schedule)
        for name in edit.RELATIONS:
            getattr(self.form, name).toggled.connect(self.schedule)
        self.timer = QtCore.QTimer()
        self.timer.setSingleShot(True)
        self.timer.timeout.connect(self.update_preview)
        self.preview = Preview(obj)
        self.edited = None
        self.dragger = None
        if facet is not None:
            # About a twentieth of the part: visible, and short of the features around it.
            size = 0.05 * float(np.linalg.norm(np.ptp(self.layer.mesh.vertices, axis=0)))
            point, normal = picked_frame(self.layer, facet)
            self.dragger = NormalDragger(self.preview.view, point, normal, size, self.dragged)
        self.parameter_changed(0)
        global active_panel
        active_panel = self

    # --- values
    def parameter(self):
        return self.choices[self.form.parameter.currentIndex()]

    def keep(self):
        return {name: getattr(self.form, name).isChecked() for name in edit.RELATIONS}

    def dragged(self, distance):
        """The arrow was dragged: a push/pull by `distance`."""
        if self.parameter()[1] != "offset":
            self.form.parameter.setCurrentIndex(0)
        self.form.value.setValue(distance)

    def parameter_changed(self, index):
        _, name, degrees = self.choices[index]
        if self.dragger is not None:
            self.dragger.show(0.0)
        value = self.current(name)
        self.form.value.blockSignals(True)
        self.form.value.setSuffix(" °" if degrees else " mm")
        self.form.value.setValue(math.degrees(value) if degrees else value)
        self.form.value.blockSignals(False)
        self.form.status.setText("")
        self.preview.hide()
        self.edited = None

    def step(self):
        return edit_step(self.feature, self.parameter()[1], self.form.value.value(), self.keep())

    def current(self, name):
        """The value of `name` before the edit: 0 for an offset, a cylinder's length along its axis
        for a hole's depth (to the floor, or through), else the parameter."""
        if name == "offset":
            return 0.0
        if name == "depth":
            params = self.feature["params"]
            axis = np.asarray(params["axis"], dtype=np.float64)
            F = np.asarray(self.layer.mesh.faces)[np.asarray(self.layer.labels) == self.feature["id"]]
            heights = self.layer.idealized_vertices[np.unique(F)] @ axis
            return round(float(heights.max() - heights.min()), 6) if len(heights) else 0.0
        return float(self.feature["params"][name])

    def unchanged(self):
        _, name, degrees = self.parameter()
        value = self.form.value.value()
        current = self.current(name)
        return value == (math.degrees(current) if degrees else current)

    # --- preview
    def schedule(self, *args):
        if self.dragger is not None and self.parameter()[1] == "offset":
            self.dragger.show(self.form.value.value())
        self.timer.start(PREVIEW_DELAY_MS)

    def update_preview(self):
        """Compute the edit (in the GUI thread: a push/pull takes well under a second) and show it,
        or say why it cannot be made."""
        if self.unchanged():
            self.preview.hide()
            self.edited = None
            self.form.status.setText("")
            return
        try:
            self.edited = edit.apply(self.layer, [self.step()])
        except (ValueError, edit.EditConflict) as error:
            self.edited = None
            self.preview.hide()
            self.form.status.setText("Cannot apply: %s" % error)
            return
        self.preview.show(self.edited)
        self.form.status.setText("Preview: %d features change (%s)." % (
            len(self.edited.changed), ", ".join(str(f) for f in self.edited.changed)))

    # --- task dialog protocol
    def getStandardButtons(self):
        from PySide import QtGui
        return int(QtGui.QDialogButtonBox.Ok | QtGui.QDialogButtonBox.Cancel)

    def accept(self):
        """Apply the edit as one undo step; regenerate the solids made from the layer's source."""
        self.timer.stop()
        if self.unchanged():
            return self.reject()
        done = apply_in_one_step(self.obj, self.step(), "Push/Pull")
        if done is None:
            return False
        layer, solids = done
        FreeCAD.Console.PrintMessage("Idealize: %s edited (features %s changed)%s\n" % (
            self.obj.Label, ", ".join(str(f) for f in layer.changed),
            "; %d solid(s) regenerated" % solids if solids else ""))
        return self._close()

    def reject(self):
        self.timer.stop()
        return self._close()

    def _close(self):
        global active_panel
        self.preview.hide()
        if self.dragger is not None:
            self.dragger.remove()
            self.dragger = None
        active_panel = None
        FreeCADGui.Control.closeDialog()
        return True
