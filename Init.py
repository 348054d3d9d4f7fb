# Idealize workbench: start-up code that FreeCAD runs with or without GUI.
#
# FreeCAD 0.20 runs this file with exec() from the function RunInitPy(Dir) in FreeCADInit.py, so
# __file__ is not this file. That function's local `Dir` (the Mod folder we were found in, e.g.
# the symlink ~/.local/share/FreeCAD/Mod/Idealize) is visible here at top level, though not
# inside functions defined here. The candidates are checked for the idealize package, so a
# wrong one is skipped; realpath() turns the symlink into the checkout it points to.
import os
import sys

import FreeCAD

for _dir in (locals().get("Dir"),
             os.path.dirname(globals().get("__file__") or ""),
             os.path.join(FreeCAD.getUserAppDataDir(), "Mod", "Idealize")):
    if _dir and os.path.isfile(os.path.join(_dir, "idealize", "__init__.py")):
        _dir = os.path.realpath(_dir)
        if _dir not in sys.path:
            sys.path.append(_dir)
        break
