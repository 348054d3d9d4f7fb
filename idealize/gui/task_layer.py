"""Task panel of the feature layer (Resources/ui/FeatureLayer.ui): the feature table with types,
key parameters, residuals and relations; rows and facets in the 3D view select each other; the
rarely needed options in a collapsed section."""
import json
import os

import FreeCADGui
import numpy as np

from .. import layer_object
from ..features import idealize
from ..freecad_mesh import mesh_check_summary
from .progress import run_with_progress

UI_FILE = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                       "Resources", "ui", "FeatureLayer.ui")
COLUMNS = ["Id", "Type", "Parameters", "RMS", "Triangles", "Relations"]


def key_parameters(feature):
    """The parameters a user looks for first: radius, axis, offset."""
    p, kind = feature["params"], feature["type"]

    def vector(v):
        # Rounded as a user reads them: an idealized axis is (0, 0, 1), not (1e-11, -2e-20, 1).
        return "(%s)" % ", ".join("%.6g" % (x + 0.0) for x in np.round(np.asarray(v, dtype=float), 4))
    if kind == "plane":
        normal = np.asarray(p["normal"], dtype=float)
        return "normal %s, offset %.4g" % (vector(normal), float(normal @ np.asarray(p["point"], dtype=float)))
    if kind == "cylinder":
        return "R %.4g, axis %s through %s" % (p["radius"], vector(p["axis"]), vector(p["point"]))
    if kind == "cone":
        return "half angle %.4g deg, axis %s, apex %s" % (np.degrees(p["half_angle"]), vector(p["axis"]),
                                                          vector(p["apex"]))
    if kind == "sphere":
        return "R %.4g, centre %s" % (p["radius"], vector(p["center"]))
    if kind == "torus":
        return "R %.4g / r %.4g, axis %s, centre %s" % (p["major"], p["minor"], vector(p["axis"]),
                                                        vector(p["center"]))
    return "no analytic surface fits"


def relations_by_feature(table):
    """{feature id: "parallel 3, 5; tangent 7"}: every relation a feature takes part in."""
    parts = {}
    for relation in table["relations"]:
        for f in relation["features"]:
            others = [str(g) for g in relation["features"] if g != f]
            parts.setdefault(f, []).append("%s %s" % (relation["kind"].replace("_", " "), ", ".join(others)))
    return {f: "; ".join(text) for f, text in parts.items()}


class FeatureLayerPanel:
    def __init__(self, obj):
        from PySide import QtGui
        self.obj = obj
        self.form = FreeCADGui.PySideUic.loadUi(UI_FILE)
        self.form.setWindowIcon(QtGui.QIcon(obj.ViewObject.Proxy.getIcon()))
        self.form.colorBy.addItems(layer_object.COLOR_MODES)
        self.form.colorBy.setCurrentIndex(layer_object.COLOR_MODES.index(obj.ViewObject.ColorBy))
        self.form.colorBy.currentIndexChanged.connect(self.color_by_changed)
        self.form.features.itemSelectionChanged.connect(self.row_selected)
        self.form.optionsToggle.toggled.connect(self.toggle_options)
        self.form.recompute.clicked.connect(self.recompute)
        self.show_options()
        self.fill()
        self.labels = np.asarray(obj.Labels, dtype=np.int64)
        FreeCADGui.Selection.addObserver(self)

    # --- content
    def fill(self):
        from PySide import QtGui
        table = json.loads(self.obj.FeatureTable)
        self.features = table["features"]
        relations = relations_by_feature(table)
        self.form.summary.setText("%d features of %s; deviation from the idealized surfaces: max %.4g, RMS %.4g.\n%s."
                                  % (len(self.features), self.obj.Source.Label if self.obj.Source else "?",
                                     table["deviation"]["max"], table["deviation"]["rms"],
                                     mesh_check_summary(table.get("mesh_check"))))
        widget = self.form.features
        widget.clear()
        widget.setColumnCount(len(COLUMNS))
        widget.setHorizontalHeaderLabels(COLUMNS)
        widget.setRowCount(len(self.features))
        for row, f in enumerate(self.features):
            cells = [str(f["id"]), f["type"], key_parameters(f), "%.3g" % f["rms"], str(f["triangles"]),
                     relations.get(f["id"], "")]
            for column, text in enumerate(cells):
                item = QtGui.QTableWidgetItem(text)
                item.setToolTip(text)
                widget.setItem(row, column, item)
        widget.resizeColumnsToContents()

    def show_options(self):
        obj = self.obj
        self.form.angleTolerance.setValue(float(obj.AngleTolerance))
        self.form.distanceTolerance.setValue(float(obj.DistanceTolerance))
        self.form.radiusTolerance.setValue(int(obj.RadiusTolerance))
        self.form.idealizeRelations.setChecked(bool(obj.IdealizeRelations))

    def toggle_options(self, shown):
        from PySide import QtCore
        self.form.options.setVisible(shown)
        self.form.optionsToggle.setArrowType(QtCore.Qt.DownArrow if shown else QtCore.Qt.RightArrow)

    # --- interaction
    def selected_feature(self):
        rows = self.form.features.selectionModel().selectedRows()
        return self.features[rows[0].row()]["id"] if rows else None

    def color_by_changed(self, index):
        self.obj.ViewObject.ColorBy = layer_object.COLOR_MODES[index]
        self.row_selected()

    def row_selected(self):
        layer_object.set_colors(self.obj, self.obj.ViewObject.ColorBy, self.selected_feature())

    def select_feature(self, feature):
        """Select the row of a feature id (as a click on its patch in the view does)."""
        for row, f in enumerate(self.features):
            if f["id"] == feature:
                self.form.features.selectRow(row)
                self.form.features.scrollToItem(self.form.features.item(row, 0))
                return

    def addSelection(self, document, name, element, point):  # Gui.Selection observer
        if document != self.obj.Document.Name or name != self.obj.Name or not element.startswith("Facet"):
            return
        facet = int(element[len("Facet"):])
        if 0 <= facet < len(self.labels) and self.labels[facet] >= 0:
            self.select_feature(int(self.labels[facet]))

    def recompute(self):
        """Recompute the layer with the options of the panel, in one undoable step."""
        from .commands import report_error
        obj, form = self.obj, self.form
        values = {"AngleTolerance": form.angleTolerance.value(), "DistanceTolerance": form.distanceTolerance.value(),
                  "RadiusTolerance": form.radiusTolerance.value(), "IdealizeRelations": form.idealizeRelations.isChecked()}
        options = layer_object.layer_options(values)
        try:
            layer = run_with_progress("Recompute feature layer", idealize, layer_object.source_mesh(obj), **options)
        except Exception as error:
            report_error("Recompute feature layer", error)
            return
        doc = obj.Document
        doc.openTransaction("Recompute feature layer")
        try:
            for name, value in values.items():
                setattr(obj, name, value)
            layer_object.apply_layer(obj, layer, options)
            doc.recompute()
            doc.commitTransaction()
        except Exception as error:
            doc.abortTransaction()
            report_error("Recompute feature layer", error)
            return
        self.labels = np.asarray(obj.Labels, dtype=np.int64)
        self.fill()

    # --- task dialog protocol
    def getStandardButtons(self):
        from PySide import QtGui
        return int(QtGui.QDialogButtonBox.Close)

    def _finish(self):
        FreeCADGui.Selection.removeObserver(self)
        layer_object.set_colors(self.obj, self.obj.ViewObject.ColorBy)  # no highlight left behind
        FreeCADGui.ActiveDocument.resetEdit()  # unsetEdit closes the dialog
        return True

    def accept(self):
        return self._finish()

    def reject(self):
        return self._finish()
