"""Task panel of the feature layer (Resources/ui/FeatureLayer.ui): the feature table (id, type, key
parameters) with the selected feature's residual, size and relations in full below it; rows and
facets in the 3D view select each other, a double-click on a row zooms to its feature; the rarely
needed options in a collapsed section. Laid out to fit the default combo view (about 260 px)."""
import json
import os

import FreeCADGui
import numpy as np

from ..freecad import layer_object
from ..freecad.mesh import mesh_check_summary, mesh_from_freecad
from .progress import run_with_progress

UI_FILE = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                       "Resources", "ui", "FeatureLayer.ui")
# Narrow enough for the default combo view; the rest of a feature is in the details below the table.
COLUMNS = ["Id", "Type", "Parameters"]
# Height of the details box: at the default dock width, a feature's parameters, residual and size
# take about three lines; a few relations fill the rest (more scroll).
DETAILS_LINES = 5


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
        # A fixed height, so the task box keeps its layout whatever the text (longer details
        # scroll): DETAILS_LINES lines and the frame.
        details = self.form.details
        details.setFixedHeight(details.fontMetrics().lineSpacing() * DETAILS_LINES
                               + 2 * (details.frameWidth() + int(details.document().documentMargin())))
        self.form.features.cellDoubleClicked.connect(lambda row, column: self.zoom_to_feature(self.features[row]["id"]))
        self.form.optionsToggle.toggled.connect(self.toggle_options)
        self.form.recompute.clicked.connect(self.recompute)
        self.show_options()
        self.fill()
        self.labels = np.asarray(obj.Labels, dtype=np.int64)
        self._mesh = None  # the layer's mesh, read on the first zoom
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
        self.details = []
        for row, f in enumerate(self.features):
            self.details.append("Feature %d, %s: %s. RMS %.3g, %d triangles.%s" % (
                f["id"], f["type"], key_parameters(f), f["rms"], f["triangles"],
                " Relations: %s." % relations[f["id"]] if f["id"] in relations else ""))
            for column, text in enumerate([str(f["id"]), f["type"], key_parameters(f)]):
                item = QtGui.QTableWidgetItem(text)
                item.setToolTip(self.details[row])
                widget.setItem(row, column, item)
        # Id and type as wide as they need, the parameters take the rest (elided, in full below).
        header = widget.horizontalHeader()
        header.setSectionResizeMode(QtGui.QHeaderView.ResizeToContents)
        header.setSectionResizeMode(COLUMNS.index("Parameters"), QtGui.QHeaderView.Stretch)
        self.show_details()

    def show_details(self):
        rows = self.form.features.selectionModel().selectedRows()
        self.form.details.setPlainText(self.details[rows[0].row()] if rows else "")

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
        self.show_details()

    def zoom_to_feature(self, feature):
        """Fit the 3D view to one feature's facets (their bounding box), keeping the view direction."""
        from pivy import coin
        gui_document = FreeCADGui.getDocument(self.obj.Document.Name)
        view = gui_document.ActiveView if gui_document is not None else None
        if not hasattr(view, "getCameraNode"):  # not a 3D view (e.g. a spreadsheet is active)
            return
        if self._mesh is None:
            self._mesh = mesh_from_freecad(self.obj.Mesh)  # global coordinates, as shown
        facets = self._mesh.faces[self.labels == feature] if len(self.labels) == self._mesh.n_triangles else []
        if not len(facets):
            return
        corners = self._mesh.vertices[facets.ravel()]
        low, high = corners.min(axis=0), corners.max(axis=0)
        width, height = view.getSize()
        # slack 1.0: the box just fits, as View > Fit selection does
        view.getCameraNode().viewBoundingBox(coin.SbBox3f(*low, *high), width / max(height, 1), 1.0)

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
        try:  # the layer's edits are replayed on the new idealization
            record = run_with_progress("Recompute feature layer", layer_object.layer_record, layer_object.source_mesh(obj),
                                       options, obj.ViewObject.ColorBy, edits=layer_object.object_edits(obj))
        except Exception as error:
            report_error("Recompute feature layer", error)
            return
        doc = obj.Document
        doc.openTransaction("Recompute feature layer")
        try:
            for name, value in values.items():
                setattr(obj, name, value)
            record.store(obj)
            doc.recompute()
            doc.commitTransaction()
        except Exception as error:
            doc.abortTransaction()
            report_error("Recompute feature layer", error)
            return
        self.labels = np.asarray(obj.Labels, dtype=np.int64)
        self._mesh = None
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
