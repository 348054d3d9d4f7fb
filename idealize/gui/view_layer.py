"""View provider of the feature layer: the idealized mesh coloured by feature type (the thesis's
colours), by feature, or by deviation with a legend; double-click opens the task panel.

Importing this module also routes the layers' recomputes (a changed option or source) through
the commands' worker thread, progress dialog and Cancel (layer_object.set_runner)."""
import json

import FreeCAD
import FreeCADGui

from ..freecad import layer_object
from ..freecad.mesh import FACE_COLORS, SURFACE_COLORS, deviation_colors
from ..progress import Cancelled
from . import icon
from .feature_highlight import FeatureHighlight, install as install_highlight_observer
from .progress import run_with_progress


def run_recompute(obj, function, *args, **kwargs):
    """layer_object's runner in the GUI: a layer's recompute (from the property editor, Ctrl+R, a
    changed source) in a worker thread behind the progress dialog, as the commands run theirs.
    Cancel returns None: the layer keeps its previous result, and is marked for a recompute again
    once this one is over (FreeCAD clears the mark after execute). No exception: FreeCAD would
    print a traceback and "Recompute failed" for what the user asked for."""
    from PySide import QtCore, QtGui
    app = QtGui.QApplication.instance()
    if app is None or QtCore.QThread.currentThread() != app.thread():
        return function(*args, **kwargs)
    title = "Recompute " + obj.Label
    try:
        return run_with_progress(title, function, *args, **kwargs)
    except Cancelled:
        message = "%s cancelled: the layer keeps its previous result; recompute, or undo the change" % title
        FreeCAD.Console.PrintMessage("Idealize: %s\n" % message)
        document, name = obj.Document.Name, obj.Name
        QtCore.QTimer.singleShot(0, lambda: _after_cancel(document, name, message))
        return None


def _after_cancel(document, name, message):
    """Once the document's recompute is over (a touch during it would make FreeCAD run the layer
    again at once, and the recompute clears the status bar): mark the layer for a recompute and
    say why."""
    from PySide import QtCore
    doc = FreeCAD.listDocuments().get(document, None)
    if doc is not None and doc.Recomputing:
        QtCore.QTimer.singleShot(0, lambda: _after_cancel(document, name, message))
        return
    obj = doc.getObject(name) if doc is not None else None
    if obj is not None:  # not closed or deleted meanwhile
        obj.touch()
    FreeCADGui.getMainWindow().statusBar().showMessage(message, 15000)


layer_object.set_runner(run_recompute)


def refresh_colors(vobj):
    """Make the mesh view show the FaceColors property again: it reads them only when Coloring is
    switched on. Not a change of the document (NoModify), so a reopened file stays unmodified."""
    if not vobj.Coloring:
        return
    vobj.setPropertyStatus("Coloring", "NoModify")
    try:
        vobj.Coloring = False
        vobj.Coloring = True
    finally:
        vobj.setPropertyStatus("Coloring", "-NoModify")


def picked_facet(picked, facets):
    """The triangle index of a Coin pick (a pivy SoPickedPoint) on a mesh of `facets` triangles, or
    None when the pick hit no face of it. The mesh's face set has one face per triangle, in order."""
    from pivy import coin
    detail = picked.getDetail()
    if detail is None or not detail.isOfType(coin.SoFaceDetail.getClassTypeId()):
        return None
    index = coin.cast(detail, "SoFaceDetail").getFaceIndex()
    return index if 0 <= index < facets else None


class ViewProviderFeatureLayer:
    def __init__(self, vobj):
        vobj.Proxy = self
        vobj.addProperty("App::PropertyEnumeration", "ColorBy", "Idealize",
                         "Colour the facets by feature type (plane light green, cylinder yellow, cone light blue, "
                         "sphere dark green, torus dark red, freeform grey), by feature, or by deviation")
        vobj.ColorBy = layer_object.COLOR_MODES
        vobj.Coloring = True

    def attach(self, vobj):
        self.Object = vobj.Object
        self.legend = None
        self.panel = None
        self.highlight = FeatureHighlight(vobj)  # the feature under the pointer and the selected ones
        install_highlight_observer()

    def _legend(self, vobj):
        if self.legend is None:
            from .legend import ColorLegend
            self.legend = ColorLegend()
            vobj.RootNode.addChild(self.legend.node)
        return self.legend

    def update_legend(self, vobj):
        """Show the deviation legend when the layer is shown by deviation, hide it otherwise."""
        deviation = vobj.Visibility and getattr(vobj, "ColorBy", "Type") == "Deviation"
        if deviation:
            obj = vobj.Object
            top = layer_object.deviation_scale(obj.VertexDeviation, json.loads(obj.FeatureTable)["distance_tolerance"])
            # Facets with no analytic surface to measure from have no deviation: freeform grey.
            self._legend(vobj).update("Deviation (mm)", top, lambda t: tuple(deviation_colors([t], 1.0)[0]),
                                      extra=[("freeform", SURFACE_COLORS["freeform"])])
        if self.legend is not None:
            self.legend.show(deviation)

    def onChanged(self, vobj, prop):
        obj = vobj.Object
        if obj is None or obj.Document.Restoring:
            return  # the saved FaceColors already are the saved mode's; finishRestoring shows them
        if prop == "ColorBy" and layer_object.is_feature_layer(obj) and obj.FeatureTable:
            layer_object.set_colors(obj, vobj.ColorBy)
            self.update_legend(vobj)
        elif prop == "Visibility":
            self.update_legend(vobj)
            if getattr(self, "highlight", None) is not None:
                self.highlight.set_visible(vobj.Visibility)

    def finishRestoring(self):
        """After a document is opened: FreeCAD 0.20 restores Coloring before the mesh view can use
        the colours (the layer would show grey), and the legend is not built yet."""
        vobj = self.Object.ViewObject
        refresh_colors(vobj)
        self.update_legend(vobj)

    def updateData(self, obj, prop):
        vobj = obj.ViewObject
        if prop in ("Mesh", "Labels") and getattr(self, "highlight", None) is not None:
            self.highlight.layer_changed()
        if prop == FACE_COLORS and vobj.Coloring:
            # The mesh view reads the colours when Coloring is switched on, not when they change.
            vobj.Coloring = False
            vobj.Coloring = True
        elif prop == "VertexDeviation" and getattr(vobj, "ColorBy", None) == "Deviation":
            self.update_legend(vobj)

    def getElementPicked(self, picked):
        """The facet under the pointer, "FacetN": a click on the layer selects that face (and so its
        feature). FreeCAD 0.20's mesh view provider names no facets (its pick is the whole object,
        "Main")."""
        facet = picked_facet(picked, self.Object.Mesh.CountFacets)
        if facet is None:
            raise NotImplementedError  # not a face of the mesh: FreeCAD's own answer
        return "Facet%d" % facet

    def getIcon(self):
        return icon("Idealize_SegmentIdealize")

    def doubleClicked(self, vobj):
        FreeCADGui.ActiveDocument.setEdit(vobj.Object.Name)
        return True

    def setEdit(self, vobj, mode=0):
        if mode != 0:
            return None
        from .task_layer import FeatureLayerPanel
        self.panel = FeatureLayerPanel(vobj.Object)  # kept for the console and tests
        FreeCADGui.Control.showDialog(self.panel)
        return True

    def unsetEdit(self, vobj, mode=0):
        if mode != 0:
            return None
        FreeCADGui.Control.closeDialog()
        self.panel = None
        return True

    # Nothing to save: attach() sets everything up again. FreeCAD 0.20 saves a proxy with
    # __getstate__ when it has one, and Python 3.11 gives every object a default one returning
    # __dict__ (here the document object, which JSON cannot hold: a traceback on every save).
    def __getstate__(self):
        return None

    def __setstate__(self, state):
        return None

    def dumps(self):  # FreeCAD before 0.20 / Python before 3.11 ask these instead
        return None

    def loads(self, state):
        return None
