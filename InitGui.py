# Idealize workbench: GUI registration, run by FreeCAD at GUI start-up.
#
# FreeCAD runs this file with exec(), so functions and methods defined here do not see the
# file's other top-level names: every method imports what it uses. Nothing here imports the
# idealize package (whose import loads the native core): start-up stays light.
import importlib.util
import os

import FreeCAD
import FreeCADGui


class IdealizeWorkbench(FreeCADGui.Workbench):
    MenuText = "Idealize"
    ToolTip = "Turn triangle meshes of mechanical parts into features and CAD"

    def Initialize(self):
        # Imported on first activation only: keeps FreeCAD start-up free of the native core.
        import idealize.gui.commands  # noqa: F401  (registers the commands)
        commands = ["Idealize_Segment", "Idealize_SegmentIdealize", "Idealize_DeviationMap", "Idealize_MakeSolid",
                    "Idealize_ExportStep", "Idealize_PushPull", "Idealize_DeleteFeature", "Idealize_MoveFeature",
                    "Idealize_CopyFeature", "Idealize_Sculpt"]
        self.appendToolbar("Idealize", commands)
        self.appendMenu("&Idealize", commands)

    def GetClassName(self):
        return "Gui::PythonWorkbench"


class IdealizeFacetColorRestorer:
    """Document observer: shows the per-facet colours of Idealize's plain meshes (the `_Segmented`
    copies: Mesh::Feature with a FaceColors property) again when a document is opened.

    FreeCAD 0.20 restores their view's Coloring before the mesh view can use the colours, so a
    reopened copy is grey until Coloring is switched off and on. Python observers get no "restore
    finished" signal in 0.20, so the switch runs on the event loop's next turn after the document
    was created, once openDocument() has returned. The feature layers (Mesh::FeaturePython) do
    the same themselves, in their view provider's finishRestoring(). Registered at start-up, so
    it works whichever workbench is active.
    """

    def slotCreatedDocument(self, doc):
        from PySide import QtCore
        name, restore = doc.Name, type(self).restore  # (no top-level names inside methods: see above)
        QtCore.QTimer.singleShot(0, lambda: restore(name))

    @staticmethod
    def restore(name):
        import FreeCAD
        doc = FreeCAD.listDocuments().get(name)
        if doc is None:  # closed before the event loop came round
            return
        for obj in doc.Objects:
            view = getattr(obj, "ViewObject", None)
            if obj.TypeId != "Mesh::Feature" or not hasattr(obj, "FaceColors") or view is None or not view.Coloring:
                continue
            # NoModify: showing what the file holds is not a change of the document.
            view.setPropertyStatus("Coloring", "NoModify")
            try:
                view.Coloring = False
                view.Coloring = True
            finally:
                view.setPropertyStatus("Coloring", "-NoModify")


# Init.py put the checkout on sys.path; find_spec locates the package without importing it.
_RESOURCES = os.path.join(os.path.dirname(os.path.dirname(importlib.util.find_spec("idealize").origin)), "Resources")
IdealizeWorkbench.Icon = os.path.join(_RESOURCES, "icons", "Idealize.svg")
# The preferences dialog finds its page icon ("preferences-idealize") by name in the icon paths.
FreeCADGui.addIconPath(os.path.join(_RESOURCES, "icons"))
# Registered at start-up, so the page is there before the workbench is first activated.
FreeCADGui.addPreferencePage(os.path.join(_RESOURCES, "ui", "PreferencesIdealize.ui"), "Idealize")
FreeCADGui.addWorkbench(IdealizeWorkbench())
FreeCAD.addDocumentObserver(IdealizeFacetColorRestorer())
