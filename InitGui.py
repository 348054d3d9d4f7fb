# Idealize workbench: GUI registration, run by FreeCAD at GUI start-up.
#
# FreeCAD runs this file with exec(), so functions and methods defined here do not see the
# file's other top-level names: every method imports what it uses.
import importlib.util
import os

import FreeCADGui


class IdealizeWorkbench(FreeCADGui.Workbench):
    MenuText = "Idealize"
    ToolTip = "Turn triangle meshes of mechanical parts into features and CAD"

    def Initialize(self):
        # Imported on first activation only: keeps FreeCAD start-up free of the native core.
        import idealize.gui.commands  # noqa: F401  (registers the commands)
        commands = ["Idealize_Segment", "Idealize_SegmentIdealize", "Idealize_DeviationMap", "Idealize_MakeSolid",
                    "Idealize_ExportStep"]
        self.appendToolbar("Idealize", commands)
        self.appendMenu("&Idealize", commands)

    def GetClassName(self):
        return "Gui::PythonWorkbench"


# Init.py put the checkout on sys.path; find_spec locates the package without importing it.
_RESOURCES = os.path.join(os.path.dirname(os.path.dirname(importlib.util.find_spec("idealize").origin)), "Resources")
IdealizeWorkbench.Icon = os.path.join(_RESOURCES, "icons", "Idealize.svg")
# Registered at start-up, so the page is there before the workbench is first activated.
FreeCADGui.addPreferencePage(os.path.join(_RESOURCES, "ui", "PreferencesIdealize.ui"), "Idealize")
FreeCADGui.addWorkbench(IdealizeWorkbench())
