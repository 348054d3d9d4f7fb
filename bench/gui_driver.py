"""Running a script in the real FreeCAD GUI under a virtual X server (xvfb-run), for the GUI test
(tests/test_gui.py) and the workbench benchmark (bench/run_gui.py).

The script body defines run(), which fills the dict `result`; it sees CONFIG (the config dict
given here, as JSON), json, os, traceback, App (FreeCAD) and Gui (FreeCADGui). Whatever run()
raises is reported as result["exception"]. The script always ends with os._exit(): the GUI would
otherwise keep running (and os._exit also keeps FreeCAD from saving its preferences).
"""
import json
import os
import subprocess
from pathlib import Path

HEADER = r'''
import json, os, traceback
import FreeCAD as App
import FreeCADGui as Gui

CONFIG = json.loads(__CONFIG__)
result = {}
'''

FOOTER = r'''

try:
    run()
except Exception:
    result["exception"] = traceback.format_exc()
with open(CONFIG["result"], "w") as f:
    json.dump(result, f, indent=1)
os._exit(0)
'''


# Synthetic mouse events on the 3D view, for the driver scripts that click and drag in it (a driver
# that uses them includes this text): mouse_events(view) gives screen(point) -> the widget position
# of a 3D point, and send(kind, position, buttons) -> that event sent to the view's viewport;
# click_feature(view, layer, feature) clicks on a feature where it shows, click_face(view, obj,
# face) on a face of a Part object.
MOUSE = r'''

def mouse_events(view):
    from PySide import QtCore, QtGui
    widget = view.graphicsView().viewport()

    def screen(point):
        sx, sy = view.getPointOnScreen(App.Vector(*point))
        return QtCore.QPoint(int(sx), int(widget.height() - sy))

    def send(kind, position, buttons):
        event = QtGui.QMouseEvent(kind, position, widget.mapToGlobal(position), QtCore.Qt.LeftButton
                                  if kind != QtCore.QEvent.MouseMove else QtCore.Qt.NoButton,
                                  buttons, QtCore.Qt.NoModifier)
        QtGui.QApplication.sendEvent(widget, event)
        QtGui.QApplication.processEvents()
    return screen, send


def click_feature(view, obj, feature):
    """Click, as a user does, on feature `feature` of the feature layer `obj` where it shows: the
    pointer moves to the centre of one of its facets that faces the viewer and that nothing hides
    (the point under that pixel is that centre), and once the face highlighted under the pointer is
    the feature's, presses and releases the left button there.
    Returns the clicked 3D point, or None when no facet of the feature shows."""
    import numpy as np
    from PySide import QtCore
    screen, send = mouse_events(view)
    points, facets = obj.Mesh.Topology
    V = np.array([tuple(p) for p in points])
    F = np.array(facets)[np.asarray(obj.Labels) == feature]
    if not len(F):
        return None
    normal = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    area = np.linalg.norm(normal, axis=1)
    facing = -(normal @ np.array(tuple(view.getViewDirection()))) / np.maximum(area, 1e-300)
    centres = V[F].mean(axis=1)
    size = np.linalg.norm(np.ptp(V, axis=0))
    for i in np.argsort(-(facing * np.sqrt(area)))[:200]:
        if facing[i] <= 0.2:  # seen edge-on or from behind
            break
        sx, sy = view.getPointOnScreen(App.Vector(*centres[i]))
        info = view.getObjectInfo((int(sx), int(sy)))
        if not info or info.get("Object") != obj.Name:
            continue
        if np.linalg.norm(np.array([info["x"], info["y"], info["z"]]) - centres[i]) > 2e-3 * size:
            continue  # hidden behind another face
        position = screen(centres[i])
        send(QtCore.QEvent.MouseMove, position, QtCore.Qt.NoButton)
        # As a user does: click once the highlight under the pointer is the feature's.
        hovered = Gui.Selection.getPreselection()
        names = hovered.SubElementNames if hovered.Object == obj else ()
        if len(names) != 1 or not names[0].startswith("Facet") or obj.Labels[int(names[0][5:])] != feature:
            continue
        send(QtCore.QEvent.MouseButtonPress, position, QtCore.Qt.LeftButton)
        send(QtCore.QEvent.MouseButtonRelease, position, QtCore.Qt.NoButton)
        return [float(c) for c in centres[i]]
    return None


def click_face(view, obj, face):
    """Click, as a user does, on face `face` (0-based: Face<face + 1>) of the Part object `obj` where
    it shows: at a point of a grid over its parameters that lies on the face, that nothing hides,
    and where the highlight under the pointer is that face. Returns the point, or None."""
    import numpy as np
    from PySide import QtCore
    screen, send = mouse_events(view)
    shape = obj.Shape.Faces[face]
    u0, u1, v0, v1 = shape.ParameterRange
    size = obj.Shape.BoundBox.DiagonalLength
    for i in range(1, 12):
        for j in range(1, 12):
            point = shape.valueAt(u0 + (u1 - u0) * i / 12.0, v0 + (v1 - v0) * j / 12.0)
            if not shape.isInside(point, 1e-6 * size, False):
                continue
            sx, sy = view.getPointOnScreen(point)
            info = view.getObjectInfo((int(sx), int(sy)))
            if not info or info.get("Object") != obj.Name or \
                    (App.Vector(info["x"], info["y"], info["z"]) - point).Length > 2e-3 * size:
                continue
            position = screen((point.x, point.y, point.z))
            send(QtCore.QEvent.MouseMove, position, QtCore.Qt.NoButton)
            hovered = Gui.Selection.getPreselection()
            if hovered.Object != obj or tuple(hovered.SubElementNames) != ("Face%d" % (face + 1),):
                continue
            send(QtCore.QEvent.MouseButtonPress, position, QtCore.Qt.LeftButton)
            send(QtCore.QEvent.MouseButtonRelease, position, QtCore.Qt.NoButton)
            return [point.x, point.y, point.z]
    return None
'''


class DriverError(RuntimeError):
    """FreeCAD ended without writing its result."""


def run_in_freecad_gui(body: str, config: dict, script: Path, timeout: int) -> dict:
    """Writes HEADER + body + FOOTER to `script` and runs it in FreeCAD's GUI (in the script's
    folder, at most `timeout` seconds); returns the result dict the script wrote to
    config["result"]. Raises DriverError with FreeCAD's output when there is none."""
    script = Path(script)
    script.write_text(HEADER.replace("__CONFIG__", repr(json.dumps(config))) + body + FOOTER)
    env = dict(os.environ, QTWEBENGINE_DISABLE_SANDBOX="1")
    env.pop("QT_QPA_PLATFORM", None)  # must use the X server xvfb-run starts
    proc = subprocess.run(["timeout", str(timeout), "xvfb-run", "-a", "-s", "-screen 0 1280x1024x24", "freecad",
                           str(script)], env=env, cwd=str(script.parent), capture_output=True, text=True)
    result = Path(config["result"])
    if not result.exists():
        raise DriverError("FreeCAD wrote no result (exit code %d%s)\n%s\n%s" % (
            proc.returncode, ", timed out" if proc.returncode == 124 else "", proc.stdout[-3000:],
            proc.stderr[-3000:]))
    return json.loads(result.read_text())
