"""FreeCAD GUI layer of Idealize: commands only; the work is done by idealize.freecad."""
import os

# Resources/ sits at the repository root, two levels above this package.
ICON_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                        "Resources", "icons")


def icon(name):
    return os.path.join(ICON_DIR, name + ".svg")
