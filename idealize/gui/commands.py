"""Idealize GUI commands. Importing this module registers them with FreeCAD."""
import time

import FreeCAD
import FreeCADGui

from .. import freecad_mesh, freecad_solid
from ..features import count_summary
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


def _show_colored_mesh(result):
    # Per-facet colours come from the FaceColors property; Coloring switches them on.
    result.ViewObject.Coloring = True


def _run_on_selection(title, transaction, compute, make_result, describe, show=_show_colored_mesh):
    """Shared body of the commands: compute on the selected mesh, add the result in one undoable
    transaction, hide the source, report; on any error abort the transaction and show it."""
    source = _selected_mesh()  # not None: FreeCAD runs commands only when IsActive()
    doc = source.Document
    start = time.perf_counter()
    doc.openTransaction(transaction)
    try:
        computed = compute(source)
        result = make_result(doc, source, computed)
        doc.recompute()
        show(result)
        # The result lies exactly on the source: hide the source so the colours do not z-fight.
        source.ViewObject.Visibility = False
        doc.commitTransaction()
    except Exception as error:  # anything: the document must not keep half a result
        doc.abortTransaction()
        _report_error(title, error)
        return
    message, details = describe(source, computed, time.perf_counter() - start)
    FreeCAD.Console.PrintMessage(message + "\n" + "".join(line + "\n" for line in details))
    FreeCADGui.getMainWindow().statusBar().showMessage(message, 15000)
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(result)


class _MeshCommand:
    """A command on the one selected mesh."""

    def IsActive(self):
        return FreeCAD.ActiveDocument is not None and _selected_mesh() is not None


class SegmentCommand(_MeshCommand):
    def GetResources(self):
        return {"Pixmap": icon("Idealize_Segment"),
                "MenuText": "Segment",
                "ToolTip": "Split the selected mesh into feature patches (fully automatic)"}

    def Activated(self):
        def describe(source, segmentation, seconds):
            return ("Idealize: %s split into %d patches (%d transition triangles) in %.2f s" % (
                source.Label, segmentation.n_features, int(segmentation.transition.sum()), seconds), [])

        _run_on_selection("Segment", "Segment mesh", freecad_mesh.segment_mesh_object,
                          freecad_mesh.make_segmented_mesh, describe)


class SegmentIdealizeCommand(_MeshCommand):
    def GetResources(self):
        return {"Pixmap": icon("Idealize_SegmentIdealize"),
                "MenuText": "Segment && Idealize",
                "ToolTip": "Find the features of the selected mesh (planes, cylinders, cones, spheres, tori) "
                           "with exact parameters; adds a copy coloured by feature type"}

    def Activated(self):
        def describe(source, layer, seconds):
            return ("Idealize: %s has %d features (%s), deviation %.3g max, in %.2f s" % (
                source.Label, len(layer.features), count_summary(layer.type_counts()), layer.deviation["max"],
                seconds),
                freecad_mesh.feature_table(layer))

        _run_on_selection("Segment & Idealize", "Segment and idealize mesh", freecad_mesh.idealize_mesh_object,
                          freecad_mesh.make_feature_mesh, describe)


class MakeSolidCommand(_MeshCommand):
    def GetResources(self):
        return {"Pixmap": icon("Idealize_MakeSolid"),
                "MenuText": "Make B-rep solid",
                "ToolTip": "Fit a solid to the selected mesh: one exact plane, cylinder, cone, sphere or torus "
                           "face per feature, plus a group of Part primitives"}

    def Activated(self):
        primitives = []

        def make_result(doc, source, computed):
            layer, solid = computed
            obj, group, _ = freecad_solid.make_solid_object(doc, source, layer, solid)
            primitives.extend(group.Group)
            return obj

        def show(obj):
            obj.ViewObject.DiffuseColor = freecad_solid.face_colors(obj.Shape)
            # The primitives lie on the solid's faces: shown, they would hide its colours.
            for primitive in primitives:
                primitive.ViewObject.Visibility = False

        def describe(source, computed, seconds):
            _, solid = computed
            state = "solid" if solid.solid else "NO valid closed solid, only faces"
            return ("Idealize: %s -> %s with %d faces (%s), volume %.6g, in %.2f s" % (
                source.Label, state, solid.faces, count_summary(solid.surface_types), solid.volume, seconds),
                ["  feature %d: %s" % (f, m) if f >= 0 else "  %s" % m for f, m in solid.problems])

        _run_on_selection("Make B-rep solid", "Make B-rep solid", freecad_solid.solid_of_mesh_object, make_result,
                          describe, show)


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
            _report_error("Export STEP", error)
            return
        FreeCAD.Console.PrintMessage("Idealize: %d object(s) written to %s\n" % (len(objects), path))


FreeCADGui.addCommand("Idealize_Segment", SegmentCommand())
FreeCADGui.addCommand("Idealize_SegmentIdealize", SegmentIdealizeCommand())
FreeCADGui.addCommand("Idealize_MakeSolid", MakeSolidCommand())
FreeCADGui.addCommand("Idealize_ExportStep", ExportStepCommand())
