"""Idealize GUI commands. Importing this module registers them with FreeCAD."""
import time

import FreeCAD
import FreeCADGui

from ..freecad import layer_object
from ..freecad import mesh as freecad_mesh
from ..freecad import solid as freecad_solid
from ..brep import make_solid
from ..features import count_summary
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
    # Nothing selected: the selection's highlight would cover the result's colours.
    FreeCADGui.Selection.clearSelection()


def _link_source(obj, source):
    """Record in obj (a coloured copy or a solid) the mesh it was made from, so that a later command
    knows what it replaces."""
    obj.addProperty("App::PropertyLink", "Source", "Idealize", "The mesh this was made from (never modified)")
    obj.Source = source


def _made_from(obj, source):
    """True when obj shows `source`'s mesh in another form: a feature layer, a coloured copy
    (`_Segmented`) or a solid made from it. Objects made before the Source link was recorded are
    known by their name."""
    if layer_object.is_feature_layer(obj):
        return obj.Source == source
    for marker, suffix in ((freecad_mesh.FACE_COLORS, "_Segmented"), ("IdealizeSolid", "_Solid")):
        if hasattr(obj, marker):
            linked = getattr(obj, "Source", None)
            return linked == source if linked is not None else obj.Name.startswith(source.Name + suffix)
    return False


def _hide_replaced(source, result):
    """Hide what `result` replaces: the source (the result lies exactly on it: colours would
    z-fight) and every other object made from it (an earlier copy, layer or solid would cover the
    result)."""
    for obj in source.Document.Objects:
        if obj != result and (obj == source or _made_from(obj, source)) and obj.ViewObject is not None:
            obj.ViewObject.Visibility = False
    result.ViewObject.Visibility = True


def _show_colored(source, result):
    result.ViewObject.Coloring = True  # per-facet colours from the FaceColors property
    _hide_replaced(source, result)


def _new_layer(title, source):
    """A :class:`LayerRecord` of a mesh object with the preferences' options, computed in a worker
    thread with progress: the worker reads a private copy of the mesh, never the document."""
    options = layer_object.layer_options(layer_object.preferences())
    kernel = source.Mesh.copy()

    def work(progress):
        return layer_object.layer_record(freecad_mesh.usable_mesh(kernel), options, progress=progress)

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
                source.Label, segmentation.n_patches, int(segmentation.transition.sum()), seconds), [])

        def make_result(doc, segmentation):
            obj = freecad_mesh.make_segmented_mesh(doc, source, segmentation)
            _link_source(obj, source)
            return obj

        kernel = source.Mesh.copy()  # the worker reads a private copy, never the document
        _run("Segment", "Segment mesh",
             lambda: run_with_progress("Segment", lambda progress: segment(freecad_mesh.usable_mesh(kernel), progress)),
             make_result, describe, lambda result: _show_colored(source, result))


class SegmentIdealizeCommand(_MeshCommand):
    def GetResources(self):
        return {"Pixmap": icon("Idealize_SegmentIdealize"),
                "MenuText": "Segment && Idealize",
                "ToolTip": "Find the features of the selected mesh (planes, cylinders, cones, spheres, tori) with "
                           "exact parameters; adds a feature layer (coloured by type; double-click for the table)"}

    def Activated(self):
        source = _selected_mesh()
        _add_layer("Segment & Idealize", "Segment and idealize mesh", source, lambda obj: _show_colored(source, obj))


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
            if layer.Source is not None:
                _hide_replaced(layer.Source, layer)
            layer.ViewObject.Visibility = True
            FreeCADGui.Selection.clearSelection()  # the highlight would cover the deviation colours
            return
        source = _selected_mesh()

        def show(obj):
            _show_colored(source, obj)
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
            _link_source(obj, source)
            primitives.extend(group.Group)
            return obj

        def show(obj):
            obj.ViewObject.DiffuseColor = freecad_solid.face_colors(obj.Shape)
            # The primitives lie on the solid's faces: shown, they would hide its colours.
            for primitive in primitives:
                primitive.ViewObject.Visibility = False
            _hide_replaced(source, obj)  # the source, the selected layer and the others made from it

        def describe(computed, seconds):
            _, solid = computed
            state = "solid" if solid.solid else "NO valid closed solid, only faces"
            return ("Idealize: %s -> %s with %d faces (%s), volume %.6g, in %.2f s" % (
                source.Label, state, solid.faces, count_summary(solid.surface_types), solid.volume, seconds),
                ["  feature %d: %s" % (f, m) if f >= 0 else "  %s" % m for f, m in solid.problems])

        _run("Make B-rep solid", "Make B-rep solid", compute, make_result, describe, show)


def _selected_layer_feature(precise=False):
    """(layer object, feature id, facet) of the one face selected in the 3D view: a facet of a
    feature layer, or a face of a B-rep solid made from one (its feature, and that feature's first
    facet in the layer; with `precise`, its facet nearest the point clicked). None otherwise."""
    selection = FreeCADGui.Selection.getSelectionEx()
    if len(selection) != 1 or len(selection[0].SubElementNames) != 1:
        return None
    obj, element = selection[0].Object, selection[0].SubElementNames[0]
    if layer_object.is_feature_layer(obj) and element.startswith("Facet"):
        facet = int(element[len("Facet"):])
        labels = obj.Labels
        if not 0 <= facet < len(labels) or labels[facet] < 0:
            return None
        return obj, int(labels[facet]), facet
    if hasattr(obj, "IdealizeFaceFeatures") and element.startswith("Face"):
        face, features = int(element[len("Face"):]) - 1, obj.IdealizeFaceFeatures
        layers = [o for o in obj.Document.Objects if layer_object.is_feature_layer(o)
                  and o.Source is not None and o.Source == getattr(obj, "Source", None)]
        if not 0 <= face < len(features) or features[face] < 0 or not layers:
            return None
        labels = layers[0].Labels  # the layer whose edits regenerate this solid (solids_of)
        if features[face] not in labels:
            return None
        facet = labels.index(features[face])
        if precise and selection[0].PickedPoints:
            facet = _facet_near(layers[0], features[face], selection[0].PickedPoints[0])
        return layers[0], features[face], facet
    return None


def _facet_near(obj, feature, point):
    """The facet of `feature` of the layer object `obj` whose centre is nearest `point`."""
    import numpy as np
    from ..freecad.mesh import mesh_from_freecad
    mesh = mesh_from_freecad(obj.Mesh)
    facets = np.flatnonzero(np.asarray(obj.Labels) == feature)
    centres = mesh.vertices[mesh.faces[facets]].mean(axis=1)
    return int(facets[np.argmin(np.linalg.norm(centres - np.array(tuple(point)), axis=1))])


class PushPullCommand:
    def GetResources(self):
        return {"Pixmap": icon("Idealize_PushPull"),
                "MenuText": "Push/Pull",
                "ToolTip": "Edit the feature of the selected face of a feature layer: move it along its normal or "
                           "change its radius or angle; fillets and related features follow, the mesh is "
                           "remeshed, and a B-rep solid made from it is regenerated"}

    def IsActive(self):
        return FreeCAD.ActiveDocument is not None and FreeCADGui.Control.activeDialog() is False \
            and _selected_layer_feature() is not None

    def Activated(self):
        from .task_push_pull import PushPullPanel
        _open_panel("Push/Pull", lambda obj, feature, facet: PushPullPanel(obj, feature, facet))


def _open_panel(title, make):
    """The task panel make(layer object, feature, facet) of the selected face, shown."""
    selected = _selected_layer_feature(precise=True)
    if selected is None:
        return
    try:
        panel = make(*selected)
    except Exception as error:
        report_error(title, error)
        return
    FreeCADGui.Selection.clearSelection()  # the highlight would hide the preview's colours
    FreeCADGui.Control.showDialog(panel)


class _FeatureGroupCommand:
    """Delete, move or copy the feature group of the selected face of a feature layer."""
    operation = "delete"
    menu = "Delete feature"
    tooltip = ""

    def GetResources(self):
        return {"Pixmap": icon("Idealize_FeatureGroup"), "MenuText": self.menu, "ToolTip": self.tooltip}

    def IsActive(self):
        return FreeCAD.ActiveDocument is not None and FreeCADGui.Control.activeDialog() is False \
            and _selected_layer_feature() is not None

    def Activated(self):
        from .task_feature_group import FeatureGroupPanel
        _open_panel(self.menu, lambda obj, feature, facet: FeatureGroupPanel(obj, feature, self.operation))


class DeleteFeatureCommand(_FeatureGroupCommand):
    operation, menu = "delete", "Delete feature"
    tooltip = ("Delete the boss, pocket or hole of the selected face of a feature layer, with its blends: its "
               "place is closed on the face around it and remeshed; a B-rep solid made from it is regenerated")


class MoveFeatureCommand(_FeatureGroupCommand):
    operation, menu = "move", "Move feature"
    tooltip = ("Move the boss, pocket or hole of the selected face of a feature layer to another place on the "
               "face it sits on, turned if asked; a B-rep solid made from it is regenerated")


class CopyFeatureCommand(_FeatureGroupCommand):
    operation, menu = "copy", "Copy feature"
    tooltip = ("Copy the boss, pocket or hole of the selected face of a feature layer to another place on the "
               "face it sits on, turned if asked; a B-rep solid made from it is regenerated")


class SculptCommand:
    def GetResources(self):
        return {"Pixmap": icon("Idealize_Sculpt"), "MenuText": "Sculpt",
                "ToolTip": "Sculpt the selected feature layer like clay: drag on it with a brush (draw, inflate, "
                           "flatten, smooth, pinch, crease, grab); the sculpted region is re-idealized into "
                           "features and a B-rep solid made from it is regenerated; each stroke is one undo step"}

    def IsActive(self):
        return FreeCAD.ActiveDocument is not None and FreeCADGui.Control.activeDialog() is False \
            and self._layer() is not None

    @staticmethod
    def _layer():
        selected = _selected_layer_feature()
        return selected[0] if selected is not None else _selected_layer()

    def Activated(self):
        from .task_sculpt import SculptPanel
        obj = self._layer()
        try:
            panel = SculptPanel(obj)
        except Exception as error:
            report_error("Sculpt", error)
            return
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Control.showDialog(panel)


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
FreeCADGui.addCommand("Idealize_PushPull", PushPullCommand())
FreeCADGui.addCommand("Idealize_DeleteFeature", DeleteFeatureCommand())
FreeCADGui.addCommand("Idealize_MoveFeature", MoveFeatureCommand())
FreeCADGui.addCommand("Idealize_CopyFeature", CopyFeatureCommand())
FreeCADGui.addCommand("Idealize_Sculpt", SculptCommand())
