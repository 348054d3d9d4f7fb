"""Task panel of Delete, Move and Copy feature (Resources/ui/FeatureGroup.ui): the group of the
selected feature (idealize.edit.feature_group) is listed and highlighted in the 3D view; members can
be ticked or unticked. Delete lifts the group off; Move and Copy place it at an offset along the face
it sits on, or onto another plane, turned about that face's normal. A preview of the edited mesh replaces the layer as the
values change, and a placement the group cannot take shows why in the panel. OK applies the edit as
one undo step and regenerates the B-rep solids made from the layer's source.
"""
import os

import FreeCADGui

from .. import edit
from ..freecad import layer_object
from .task_push_pull import PREVIEW_DELAY_MS, Preview, apply_in_one_step

UI_FILE = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                       "Resources", "ui", "FeatureGroup.ui")
#: The operations of the panel: (label, op of idealize.edit.apply, undo step's name).
OPERATIONS = [("Delete", "delete", "Delete feature"), ("Move", "move", "Move feature"),
              ("Copy", "copy", "Copy feature")]


def group_step(operation, members, translation=(0.0, 0.0, 0.0), rotation=0.0, onto=None):
    """The edit (a dict for idealize.edit.apply) of the panel's values; `onto`: another plane's id."""
    step = {"op": operation, "feature_ids": [int(m) for m in members]}
    if operation != "delete":
        step["translation"] = [float(x) for x in translation]
        step["rotation"] = float(rotation)
        if onto is not None:
            step["onto"] = int(onto)
    return step


def neighbours(layer, members):
    """The features that border `members` (from the layer's adjacency), sorted."""
    inside = set(members)
    out = set()
    for a in layer.adjacency:
        if a["a"] in inside and a["b"] not in inside:
            out.add(a["b"])
        if a["b"] in inside and a["a"] not in inside:
            out.add(a["a"])
    return sorted(out)


#: The panel open now (None when none is): for macros and tests.
active_panel = None


class FeatureGroupPanel:
    def __init__(self, obj, feature_id, operation="delete"):
        from PySide import QtCore, QtGui
        from .task_layer import key_parameters
        self.obj = obj
        self.layer = layer_object.feature_layer(obj)
        group = edit.feature_group(self.layer, feature_id)
        self.hosts = group["hosts"]
        self.form = FreeCADGui.PySideUic.loadUi(UI_FILE)
        self.form.setWindowIcon(QtGui.QIcon(os.path.join(os.path.dirname(UI_FILE), "..", "icons",
                                                         "Idealize_FeatureGroup.svg")))
        self.form.group.setText("Group of feature %d: %d features on %s." % (
            feature_id, len(group["members"]),
            ", ".join("feature %d (%s)" % (h, self.layer.features[h]["type"]) for h in self.hosts)
            if self.hosts else "no face of its own (a face of the part's outline)"))
        self.form.members.blockSignals(True)
        for f in group["members"] + neighbours(self.layer, group["members"]):
            feature = self.layer.features[f]
            item = QtGui.QListWidgetItem("%d: %s, %s" % (f, feature["type"], key_parameters(feature)))
            item.setData(QtCore.Qt.UserRole, f)
            item.setFlags(item.flags() | QtCore.Qt.ItemIsUserCheckable)
            item.setCheckState(QtCore.Qt.Checked if f in group["members"] else QtCore.Qt.Unchecked)
            self.form.members.addItem(item)
        self.form.members.blockSignals(False)
        self.form.members.itemChanged.connect(self.schedule)
        # Onto: the face it sits on, or another plane of the layer.
        self.form.onto.addItem("The face it sits on", None)
        for f in self.layer.features:
            if f["type"] == "plane" and f["id"] not in group["members"] and f["id"] not in self.hosts:
                self.form.onto.addItem("%d: plane, %s" % (f["id"], key_parameters(f)), int(f["id"]))
        self.form.onto.currentIndexChanged.connect(self.schedule)
        self.form.operation.addItems([label for label, _, _ in OPERATIONS])
        self.form.operation.setCurrentIndex([op for _, op, _ in OPERATIONS].index(operation))
        self.form.operation.currentIndexChanged.connect(self.operation_changed)
        for name in ("offsetX", "offsetY", "offsetZ"):
            getattr(self.form, name).setRange(-1e9, 1e9)
            getattr(self.form, name).valueChanged.connect(self.schedule)
        self.form.rotation.valueChanged.connect(self.schedule)
        self.timer = QtCore.QTimer()
        self.timer.setSingleShot(True)
        self.timer.timeout.connect(self.update_preview)
        self.preview = Preview(obj)
        self.edited = None
        global active_panel
        active_panel = self
        self.operation_changed(self.form.operation.currentIndex())

    # --- values
    def members(self):
        from PySide import QtCore
        items = [self.form.members.item(i) for i in range(self.form.members.count())]
        return [int(item.data(QtCore.Qt.UserRole)) for item in items if item.checkState() == QtCore.Qt.Checked]

    def operation(self):
        return OPERATIONS[self.form.operation.currentIndex()]

    def step(self):
        translation = [getattr(self.form, name).value() for name in ("offsetX", "offsetY", "offsetZ")]
        return group_step(self.operation()[1], self.members(), translation, self.form.rotation.value(),
                          self.form.onto.itemData(self.form.onto.currentIndex()))

    def unchanged(self):
        step = self.step()
        return not step["feature_ids"] or (
            step["op"] == "move" and not any(step["translation"]) and not step["rotation"] and "onto" not in step)

    def operation_changed(self, index):
        placing = OPERATIONS[index][1] != "delete"
        for name in ("onto", "offsetX", "offsetY", "offsetZ", "rotation"):
            getattr(self.form, name).setEnabled(placing)
        self.schedule()

    # --- preview
    def schedule(self, *args):
        self.timer.start(PREVIEW_DELAY_MS)

    def update_preview(self):
        """The group highlighted while nothing changes; else the edit computed (in the GUI thread:
        it takes well under a second) and shown, or why it cannot be made."""
        members = self.members()
        if self.unchanged():
            self.edited = None
            self.preview.show(self.layer, highlight=members)
            self.form.status.setText("" if members else "No feature ticked.")
            return
        try:
            self.edited = edit.apply(self.layer, [self.step()])
        except (ValueError, edit.EditConflict) as error:
            self.edited = None
            self.preview.show(self.layer, highlight=members)
            self.form.status.setText("Cannot apply: %s" % error)
            return
        placed = getattr(self.edited, "copies", None) or (members if self.step()["op"] == "move" else [])
        self.preview.show(self.edited, highlight=placed)
        self.form.status.setText("Preview: %d features, %d triangles made." % (
            len(self.edited.features), int(self.edited.created.sum())))

    # --- task dialog protocol
    def getStandardButtons(self):
        from PySide import QtGui
        return int(QtGui.QDialogButtonBox.Ok | QtGui.QDialogButtonBox.Cancel)

    def accept(self):
        """Apply the edit as one undo step; regenerate the solids made from the layer's source."""
        import FreeCAD
        self.timer.stop()
        if self.unchanged():
            return self.reject()
        title = self.operation()[2]
        done = apply_in_one_step(self.obj, self.step(), title)
        if done is None:
            return False
        layer, solids = done
        FreeCAD.Console.PrintMessage("Idealize: %s: %s, %d features now%s\n" % (
            self.obj.Label, title.lower(), len(layer.features),
            "; %d solid(s) regenerated" % solids if solids else ""))
        return self._close()

    def reject(self):
        self.timer.stop()
        return self._close()

    def _close(self):
        global active_panel
        self.preview.hide()
        active_panel = None
        FreeCADGui.Control.closeDialog()
        return True
