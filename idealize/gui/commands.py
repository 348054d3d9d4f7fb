"""Idealize GUI commands. Importing this module registers them with FreeCAD."""
import time

import FreeCAD
import FreeCADGui

from .. import freecad_mesh
from . import icon


def _selected_mesh():
    """The selected Mesh::Feature if it is the only selected object, else None."""
    selection = FreeCADGui.Selection.getSelection()
    if len(selection) == 1 and selection[0].isDerivedFrom("Mesh::Feature"):
        return selection[0]
    return None


def _report_error(title, error):
    from PySide import QtGui
    message = str(error) or type(error).__name__
    FreeCAD.Console.PrintError("Idealize: %s failed: %s\n" % (title, message))
    QtGui.QMessageBox.critical(FreeCADGui.getMainWindow(), "Idealize - " + title, message)


class SegmentCommand:
    def GetResources(self):
        return {"Pixmap": icon("Idealize_Segment"),
                "MenuText": "Segment",
                "ToolTip": "Split the selected mesh into feature patches (fully automatic)"}

    def IsActive(self):
        return FreeCAD.ActiveDocument is not None and _selected_mesh() is not None

    def Activated(self):
        source = _selected_mesh()  # not None: FreeCAD runs commands only when IsActive()
        doc = source.Document
        start = time.perf_counter()
        doc.openTransaction("Segment mesh")
        try:
            segmentation = freecad_mesh.segment_mesh_object(source)
            result = freecad_mesh.make_segmented_mesh(doc, source, segmentation)
            doc.recompute()
            # Per-facet colours come from the FaceColors property; Coloring switches them on.
            result.ViewObject.Coloring = True
            # The copy lies exactly on the source: hide the source so the colours do not z-fight.
            source.ViewObject.Visibility = False
            doc.commitTransaction()
        except Exception as error:  # anything: the document must not keep half a result
            doc.abortTransaction()
            _report_error("Segment", error)
            return
        seconds = time.perf_counter() - start
        transition = int(segmentation.transition.sum())
        message = "Idealize: %s split into %d patches (%d transition triangles) in %.2f s" % (
            source.Label, segmentation.n_features, transition, seconds)
        FreeCAD.Console.PrintMessage(message + "\n")
        FreeCADGui.getMainWindow().statusBar().showMessage(message, 15000)
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(result)


class SegmentIdealizeCommand:
    def GetResources(self):
        return {"Pixmap": icon("Idealize_SegmentIdealize"),
                "MenuText": "Segment && Idealize",
                "ToolTip": "Find the features of the selected mesh (planes, cylinders, cones, spheres, tori) "
                           "with exact parameters; adds a copy coloured by feature type"}

    def IsActive(self):
        return FreeCAD.ActiveDocument is not None and _selected_mesh() is not None

    def Activated(self):
        source = _selected_mesh()
        doc = source.Document
        start = time.perf_counter()
        doc.openTransaction("Segment and idealize mesh")
        try:
            layer = freecad_mesh.idealize_mesh_object(source)
            result = freecad_mesh.make_feature_mesh(doc, source, layer)
            doc.recompute()
            result.ViewObject.Coloring = True
            source.ViewObject.Visibility = False
            doc.commitTransaction()
        except Exception as error:  # anything: the document must not keep half a result
            doc.abortTransaction()
            _report_error("Segment & Idealize", error)
            return
        seconds = time.perf_counter() - start
        kinds = ", ".join("%d %s" % (n, t) for t, n in sorted(layer.type_counts().items()))
        message = "Idealize: %s has %d features (%s), deviation %.3g max, in %.2f s" % (
            source.Label, len(layer.features), kinds, layer.deviation["max"], seconds)
        FreeCAD.Console.PrintMessage(message + "\n" + "\n".join(freecad_mesh.feature_table(layer)) + "\n")
        FreeCADGui.getMainWindow().statusBar().showMessage(message, 15000)
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(result)


FreeCADGui.addCommand("Idealize_Segment", SegmentCommand())
FreeCADGui.addCommand("Idealize_SegmentIdealize", SegmentIdealizeCommand())
