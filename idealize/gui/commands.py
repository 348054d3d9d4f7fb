"""Idealize GUI commands. Importing this module registers them with FreeCAD."""
import time

import FreeCAD
import FreeCADGui

from .. import freecad_mesh, freecad_solid, layer_object
from ..brep import make_solid
from ..features import count_summary, idealize
from ..segmentation import segment
from . import icon
from ..progress import Cancelled
from .progress import run_with_progress


def _selected_mesh():
    """The selected Mesh::Feature if it is the only selected object, else None."""
    selection = FreeCADGui.Selection.getSelection()
    if len(selection) == 1 and selection[0].isDerivedFrom("Mesh::Feature") \
            and not layer_object.is_feature_layer(selection[0]):
        return selection[0]
    return None


def _selected_layer():
    """The selected feature layer object if it is the only selected object, else None."""
    selection = FreeCADGui.Selection.getSelection()
    if len(selection) == 1 and layer_object.is_feature_layer(selection[0]):
        return selection[0]
    return None


def report_error(title, error):
    """Show an error in the report view and a message box (a cancel only in the status bar)."""
    from PySide import QtGui
    if isinstance(error, Cancelled):
        FreeCAD.Console.PrintMessage("Idealize: %s cancelled; the document is unchanged\n" % title)
        FreeCADGui.getMainWindow().statusBar().showMessage("%s cancelled" % title, 5000)
        return
    message = str(error) or type(error).__name__
    FreeCAD.Console.PrintError("Idealize: %s failed: %s\n" % (title, message))
    QtGui.QMessageBox.critical(FreeCADGui.getMainWindow(), "Idealize - " + title, message)


def _run(title, transaction, compute, make_result, describe, show):
    """Shared body of the commands: compute (in a worker thread with progress and Cancel), then
    add the result in one undoable transaction and report; on any error or cancel the
    transaction is aborted and the document stays as it was."""
    doc = FreeCAD.ActiveDocument
    start = time.perf_counter()
    try:
        computed = compute()
    except Exception as error:
        report_error(title, error)
        return
    doc.openTransaction(transaction)
    try:
        result = make_result(doc, computed)
        doc.recompute()
        show(result)
        doc.commitTransaction()
    except Exception as error:  # anything: the document must not keep half a result
        doc.abortTransaction()
        report_error(title, error)
        return
    message, details = describe(computed, time.perf_counter() - start)
    FreeCAD.Console.PrintMessage(message + "\n" + "".join(line + "\n" for line in details))
    FreeCADGui.getMainWindow().statusBar().showMessage(message, 15000)
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(result)


def _hide_source(source, result):
    # The result lies exactly on the source: hide the source so the colours do not z-fight.
    result.ViewObject.Coloring = True  # per-facet colours from the FaceColors property
    source.ViewObject.Visibility = False


def _new_layer(title, source):
    """A :class:`LayerRecord` of a mesh object with the preferences' options, computed in a worker
    thread with progress: the worker reads a private copy of the mesh, never the document."""
    options = layer_object.layer_options(layer_object.preferences())
    kernel = source.Mesh.copy()

    def work(progress):
        layer = idealize(freecad_mesh.usable_mesh(kernel), progress=progress, **options)
        progress.report("preparing the document", 1.0)
        return layer_object.LayerRecord(layer, options)

    return run_with_progress(title, work)


def _add_layer(title, transaction, source, show):
    """A new feature layer of a mesh object, in one transaction (the shared body of the commands
    that make one)."""
    def describe(record, seconds):
        layer = record.layer
        return ("Idealize: %s has %d features (%s), deviation %.3g max, in %.2f s" % (
            source.Label, len(layer.features), count_summary(layer.type_counts()), layer.deviation["max"], seconds),
            freecad_mesh.feature_table(layer))

    _run(title, transaction, lambda: _new_layer(title, source),
         lambda doc, record: layer_object.make_feature_layer(source, record), describe, show)


class _MeshCommand:
    """A command on the one selected mesh."""

    def IsActive(self):
        return FreeCAD.ActiveDocument is not None and _selected_mesh() is not None


class _LayerOrMeshCommand:
    """A command on the one selected feature layer or mesh."""

    def IsActive(self):
        return FreeCAD.ActiveDocument is not None and (_selected_layer() is not None or _selected_mesh() is not None)


class SegmentCommand(_MeshCommand):
    def GetResources(self):
        return {"Pixmap": icon("Idealize_Segment"),
                "MenuText": "Segment",
                "ToolTip": "Split the selected mesh into feature patches (fully automatic); adds a copy coloured "
                           "by patch"}

    def Activated(self):
        source = _selected_mesh()

        def describe(segmentation, seconds):
            return ("Idealize: %s split into %d patches (%d transition triangles) in %.2f s" % (
                source.Label, segmentation.n_features, int(segmentation.transition.sum()), seconds), [])

        kernel = source.Mesh.copy()  # the worker reads a private copy, never the document
        _run("Segment", "Segment mesh",
             lambda: run_with_progress("Segment", lambda progress: segment(freecad_mesh.usable_mesh(kernel), progress)),
             lambda doc, segmentation: freecad_mesh.make_segmented_mesh(doc, source, segmentation), describe,
             lambda result: _hide_source(source, result))


class SegmentIdealizeCommand(_MeshCommand):
    def GetResources(self):
        return {"Pixmap": icon("Idealize_SegmentIdealize"),
                "MenuText": "Segment && Idealize",
                "ToolTip": "Find the features of the selected mesh (planes, cylinders, cones, spheres, tori) with "
                           "exact parameters; adds a feature layer (coloured by type; double-click for the table)"}

    def Activated(self):
        source = _selected_mesh()
        _add_layer("Segment & Idealize", "Segment and idealize mesh", source, lambda obj: _hide_source(source, obj))


class DeviationMapCommand(_LayerOrMeshCommand):
    def GetResources(self):
        return {"Pixmap": icon("Idealize_DeviationMap"),
                "MenuText": "Deviation map",
                "ToolTip": "Colour the selected feature layer (or a new layer of the selected mesh) by the distance "
                           "of the mesh from the idealized surfaces, with a legend"}

    def Activated(self):
        layer = _selected_layer()
        if layer is not None:
            layer.ViewObject.ColorBy = "Deviation"  # a view setting: not an undoable document change
            layer.ViewObject.Visibility = True
            return
        source = _selected_mesh()

        def show(obj):
            _hide_source(source, obj)
            obj.ViewObject.ColorBy = "Deviation"

        _add_layer("Deviation map", "Deviation map", source, show)


class MakeSolidCommand(_LayerOrMeshCommand):
    def GetResources(self):
        return {"Pixmap": icon("Idealize_MakeSolid"),
                "MenuText": "Make B-rep solid",
                "ToolTip": "Fit a solid to the selected feature layer or mesh: one exact plane, cylinder, cone, "
                           "sphere or torus face per feature, plus a group of Part primitives"}

    def Activated(self):
        selected_layer = _selected_layer()
        source = selected_layer.Source if selected_layer is not None else _selected_mesh()
        primitives = []

        def compute():
            layer = (layer_object.feature_layer(selected_layer) if selected_layer is not None
                     else _new_layer("Segment & Idealize", source).layer)
            return layer, run_with_progress("Make B-rep solid", make_solid, layer)

        def make_result(doc, computed):
            layer, solid = computed
            obj, group, _ = freecad_solid.make_solid_object(doc, source, layer, solid)
            primitives.extend(group.Group)
            return obj

        def show(obj):
            obj.ViewObject.DiffuseColor = freecad_solid.face_colors(obj.Shape)
            # The primitives lie on the solid's faces: shown, they would hide its colours.
            for primitive in primitives:
                primitive.ViewObject.Visibility = False
            for hidden in (source, selected_layer):
                if hidden is not None:
                    hidden.ViewObject.Visibility = False

        def describe(computed, seconds):
            _, solid = computed
            state = "solid" if solid.solid else "NO valid closed solid, only faces"
            return ("Idealize: %s -> %s with %d faces (%s), volume %.6g, in %.2f s" % (
                source.Label, state, solid.faces, count_summary(solid.surface_types), solid.volume, seconds),
                ["  feature %d: %s" % (f, m) if f >= 0 else "  %s" % m for f, m in solid.problems])

        _run("Make B-rep solid", "Make B-rep solid", compute, make_result, describe, show)


def _selected_shapes():
    return [o for o in FreeCADGui.Selection.getSelection() if o.isDerivedFrom("Part::Feature")]


class ExportStepCommand:
    def GetResources(self):
        return {"Pixmap": icon("Idealize_ExportStep"),
                "MenuText": "Export STEP",
                "ToolTip": "Write the selected solid (or Part objects) to a STEP file"}

    def IsActive(self):
        return FreeCAD.ActiveDocument is not None and bool(_selected_shapes())

    def Activated(self):
        from PySide import QtGui
        objects = _selected_shapes()
        path, _ = QtGui.QFileDialog.getSaveFileName(FreeCADGui.getMainWindow(), "Export STEP",
                                                    objects[0].Label + ".step", "STEP (*.step *.stp)")
        if not path:
            return
        try:
            freecad_solid.export_step(objects, path)
        except Exception as error:
            report_error("Export STEP", error)
            return
        FreeCAD.Console.PrintMessage("Idealize: %d object(s) written to %s\n" % (len(objects), path))


FreeCADGui.addCommand("Idealize_Segment", SegmentCommand())
FreeCADGui.addCommand("Idealize_SegmentIdealize", SegmentIdealizeCommand())
FreeCADGui.addCommand("Idealize_DeviationMap", DeviationMapCommand())
FreeCADGui.addCommand("Idealize_MakeSolid", MakeSolidCommand())
FreeCADGui.addCommand("Idealize_ExportStep", ExportStepCommand())
