"""GUI test: FreeCAD finds the workbench through a symlink in its user Mod folder, and
Idealize_Segment makes a coloured, undoable copy of the selected mesh.

Runs the real FreeCAD GUI under a virtual X server (xvfb-run), with a driver script that
reports back through a JSON file. Skipped when xvfb-run or freecad is missing.
"""
import json
import os
import shutil
import subprocess

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Runs inside FreeCAD. CONFIG is filled in by the test. Always ends with os._exit(): the GUI
# would otherwise keep running (and os._exit also keeps FreeCAD from saving its preferences).
DRIVER = r'''
import json, os, traceback
import FreeCAD as App
import FreeCADGui as Gui

CONFIG = json.loads(__CONFIG__)
result = {}


def ensure_link():
    """Point <user Mod>/Idealize at the checkout under test; True when it had to change."""
    mod = os.path.join(App.getUserAppDataDir(), "Mod")
    link = os.path.join(mod, "Idealize")
    result["link"] = link
    if os.path.islink(link):
        if os.path.realpath(link) == os.path.realpath(CONFIG["repo"]):
            return False
        os.remove(link)
    elif os.path.exists(link):
        raise RuntimeError("%s exists and is not a symlink: move it away to run this test" % link)
    os.makedirs(mod, exist_ok=True)
    os.symlink(CONFIG["repo"], link)
    return True


def red_and_colour_counts(path):
    """Screenshot pixels: how many are red, and how many hues (30 degree bins) cover at least
    0.5% of it each; shading changes brightness, not hue, so one colour is one hue."""
    import numpy as np
    from PySide import QtGui
    image = QtGui.QImage(path).convertToFormat(QtGui.QImage.Format_RGB32)
    bgra = np.frombuffer(bytes(image.constBits()), np.uint8).reshape(image.height(), -1, 4)
    rgb = bgra[:, :image.width(), 2::-1].reshape(-1, 3).astype(int)
    coloured = rgb[rgb.max(axis=1) - rgb.min(axis=1) > 40]  # not white, black or grey
    red, area = 0, {}
    for (r, g, b), n in zip(*(a.tolist() for a in np.unique(coloured, axis=0, return_counts=True))):
        if r > 100 and g < r / 2 and b < r / 2:
            red += n
        else:
            hue = QtGui.QColor(r, g, b).hue() // 30
            area[hue] = area.get(hue, 0) + n
    return red, sum(n >= 0.005 * len(rgb) for n in area.values())


def run_on(doc, obj, command):
    """Run a command with obj selected; the objects it added."""
    Gui.Selection.clearSelection()
    Gui.Selection.addSelection(obj)
    names = {o.Name for o in doc.Objects}
    Gui.runCommand(command)
    Gui.updateGui()
    return [o for o in doc.Objects if o.Name not in names]


def run():
    if ensure_link():
        result["restart"] = True  # FreeCAD scans the Mod folders only at start-up
        return
    result["workbenches"] = sorted(Gui.listWorkbenches())
    if "IdealizeWorkbench" not in result["workbenches"]:
        return

    from PySide import QtGui
    import Part, MeshPart
    # A failing command would block on its modal error box: record the message instead.
    result["error_boxes"] = []
    QtGui.QMessageBox.critical = lambda parent, title, text, *rest: result["error_boxes"].append(text)

    Gui.activateWorkbench("IdealizeWorkbench")
    result["active_workbench"] = Gui.activeWorkbench().name()
    import idealize
    result["idealize_file"] = os.path.realpath(idealize.__file__)

    doc = App.newDocument("IdealizeGuiTest")
    shape = Part.makeBox(30, 20, 10).cut(Part.makeCylinder(4, 10, App.Vector(15, 10, 0)))
    source = doc.addObject("Mesh::Feature", "Part")
    source.Mesh = MeshPart.meshFromShape(Shape=shape, MaxLength=1.5)
    doc.recompute()
    counts = lambda: [source.Mesh.CountPoints, source.Mesh.CountFacets]
    result["source_before"] = counts()

    Gui.Selection.clearSelection()
    result["active_without_selection"] = Gui.isCommandActive("Idealize_Segment")
    Gui.Selection.addSelection(source)
    result["active_with_selection"] = Gui.isCommandActive("Idealize_Segment")

    new = run_on(doc, source, "Idealize_Segment")
    result["new_labels"] = [o.Label for o in new]
    result["source_after"] = counts()
    result["undo_names"] = doc.UndoNames
    result["status_message"] = Gui.getMainWindow().statusBar().currentMessage()
    if new:
        obj = new[0]
        result["facets"] = obj.Mesh.CountFacets
        result["face_colors"] = len(obj.FaceColors)
        result["distinct_face_colors"] = len(set(obj.FaceColors))
        result["coloring"] = obj.ViewObject.Coloring
        result["source_visible"] = source.ViewObject.Visibility
        view = Gui.ActiveDocument.ActiveView
        view.viewIsometric()
        view.fitAll()
        Gui.Selection.clearSelection()  # selection highlight would hide the patch colours
        Gui.updateGui()
        view.saveImage(CONFIG["screenshot"], 800, 600, "White")
        result["red_pixels"], result["hues"] = red_and_colour_counts(CONFIG["screenshot"])

    doc.undo()
    result["objects_after_undo"] = [o.Label for o in doc.Objects]
    result["source_visible_after_undo"] = source.ViewObject.Visibility

    # Segment & Idealize: a copy coloured by feature type, undone in one step.
    new = run_on(doc, source, "Idealize_SegmentIdealize")
    result["idealize_labels"] = [o.Label for o in new]
    result["idealize_undo_name"] = doc.UndoNames[0] if doc.UndoNames else None
    if new:
        from idealize.freecad_mesh import SURFACE_COLORS
        palette = {tuple(round(c, 2) for c in rgb): t for t, rgb in SURFACE_COLORS.items()}
        seen = {}
        for c in new[0].FaceColors:
            t = palette.get(tuple(round(x, 2) for x in c[:3]), "other")
            seen[t] = seen.get(t, 0) + 1
        result["idealize_type_colors"] = seen
        Gui.Selection.clearSelection()
        view = Gui.ActiveDocument.ActiveView
        view.viewIsometric()
        view.fitAll()
        Gui.updateGui()
        view.saveImage(CONFIG["screenshot_types"], 800, 600, "White")
    doc.undo()
    result["objects_after_idealize_undo"] = [o.Label for o in doc.Objects]

    # Make B-rep solid: a Part solid coloured by face type and a group of primitives, one undo.
    new = run_on(doc, source, "Idealize_MakeSolid")
    result["solid_labels"] = sorted(o.Label for o in new)
    result["solid_undo_name"] = doc.UndoNames[0] if doc.UndoNames else None
    solids = [o for o in new if o.Label == "Part_Solid"]
    if solids:
        solid = solids[0]
        result["solid"] = {"valid": solid.Shape.isValid(), "type": solid.Shape.ShapeType,
                           "faces": len(solid.Shape.Faces), "volume": solid.Shape.Volume,
                           "colors": len(solid.ViewObject.DiffuseColor), "flag": solid.IdealizeSolid}
        group = [o for o in new if o.Label == "Part_Primitives"][0]
        result["primitives"] = sorted(o.Shape.ShapeType for o in group.Group)
        Gui.Selection.clearSelection()
        source.ViewObject.Visibility = False
        view = Gui.ActiveDocument.ActiveView
        view.viewIsometric()
        view.fitAll()
        Gui.updateGui()
        view.saveImage(CONFIG["screenshot_solid"], 800, 600, "White")
        # Export STEP through the command, the file dialog answered by the test.
        QtGui.QFileDialog.getSaveFileName = lambda *args, **kw: (CONFIG["step"], "")
        Gui.Selection.addSelection(solid)
        result["export_active"] = Gui.isCommandActive("Idealize_ExportStep")
        Gui.runCommand("Idealize_ExportStep")
        back = Part.read(CONFIG["step"])
        result["step"] = {"solids": len(back.Solids), "faces": len(back.Faces), "valid": back.isValid()}
    doc.undo()
    result["objects_after_solid_undo"] = [o.Label for o in doc.Objects]

    # A mesh the core rejects: the transaction is aborted and the error is shown.
    empty = doc.addObject("Mesh::Feature", "Empty")
    doc.recompute()
    undo_count = len(doc.UndoNames)
    Gui.Selection.clearSelection()
    Gui.Selection.addSelection(empty)
    Gui.runCommand("Idealize_Segment")
    result["objects_after_error"] = [o.Label for o in doc.Objects]
    result["undo_added_by_error"] = len(doc.UndoNames) - undo_count


try:
    run()
except Exception:
    result["exception"] = traceback.format_exc()
with open(CONFIG["result"], "w") as f:
    json.dump(result, f, indent=1)
os._exit(0)
'''


def run_driver(tmp_path, attempt):
    config = {"repo": REPO, "result": str(tmp_path / ("result%d.json" % attempt)),
              "screenshot": str(tmp_path / "segment-gui.png"),
              "screenshot_types": str(tmp_path / "idealize-gui.png"),
              "screenshot_solid": str(tmp_path / "solid-gui.png"), "step": str(tmp_path / "part.step")}
    script = tmp_path / ("driver%d.py" % attempt)
    script.write_text(DRIVER.replace("__CONFIG__", repr(json.dumps(config))))
    env = dict(os.environ, QTWEBENGINE_DISABLE_SANDBOX="1")
    env.pop("QT_QPA_PLATFORM", None)  # must use the X server xvfb-run starts
    proc = subprocess.run(["timeout", "240", "xvfb-run", "-a", "-s", "-screen 0 1280x1024x24",
                           "freecad", str(script)],
                          env=env, cwd=str(tmp_path), capture_output=True, text=True)
    if not os.path.exists(config["result"]):
        pytest.fail("FreeCAD wrote no result (exit code %d%s)\n%s\n%s" % (
            proc.returncode, ", timed out" if proc.returncode == 124 else "",
            proc.stdout[-3000:], proc.stderr[-3000:]))
    with open(config["result"]) as f:
        return json.load(f), config


def test_segment_command_in_freecad_gui(tmp_path):
    for tool in ("xvfb-run", "freecad", "timeout"):
        if shutil.which(tool) is None:
            pytest.skip("%s is not installed; the GUI test runs FreeCAD under xvfb-run" % tool)

    # The first run after the link was (re)created only creates it: FreeCAD must restart.
    result, config = run_driver(tmp_path, 1)
    if result.get("restart"):
        result, config = run_driver(tmp_path, 2)
    print(json.dumps(result, indent=1))

    assert "exception" not in result, result["exception"]
    assert not result.get("restart"), "FreeCAD did not pick up the new link %s" % result["link"]
    assert "IdealizeWorkbench" in result["workbenches"], "FreeCAD does not list the workbench"
    assert result["active_workbench"] == "IdealizeWorkbench"
    assert result["idealize_file"].startswith(os.path.realpath(REPO) + os.sep)

    assert result["active_without_selection"] is False
    assert result["active_with_selection"] is True
    assert result["new_labels"] == ["Part_Segmented"]
    assert result["source_after"] == result["source_before"]
    assert result["undo_names"][0] == "Segment mesh"
    assert "patches" in result["status_message"]

    assert result["face_colors"] == result["facets"] == result["source_before"][1]
    assert result["distinct_face_colors"] >= 4  # several patches plus red transitions
    assert result["coloring"] is True
    assert result["source_visible"] is False
    # Transition triangles are thin slivers along the edges: few, but some, red pixels.
    assert result["red_pixels"] > 20, "no red transitions in the screenshot"
    assert result["hues"] >= 3, "patch colours do not show in the screenshot"

    assert result["objects_after_undo"] == ["Part"]
    assert result["source_visible_after_undo"] is True

    # Box with a hole: 6 planes (light green) and the hole's cylinder (yellow), nothing else.
    assert result["idealize_labels"] == ["Part_Features"]
    assert result["idealize_undo_name"] == "Segment and idealize mesh"
    colors = result["idealize_type_colors"]
    assert set(colors) == {"plane", "cylinder"}, colors
    assert sum(colors.values()) == result["source_before"][1]
    assert result["objects_after_idealize_undo"] == ["Part"]

    # The fitted solid: 7 faces, exact volume, coloured, with 7 primitives; one undo removes all.
    assert {"Part_Solid", "Part_Primitives"} <= set(result["solid_labels"])
    assert result["solid_undo_name"] == "Make B-rep solid"
    solid = result["solid"]
    assert solid["valid"] and solid["type"] == "Solid" and solid["flag"] is True
    assert solid["faces"] == 7 and solid["colors"] == 7
    assert abs(solid["volume"] - (30 * 20 * 10 - 3.141592653589793 * 16 * 10)) < 1e-3 * solid["volume"]
    assert result["primitives"].count("Face") == 6 and result["primitives"].count("Solid") == 1
    assert result["export_active"] is True
    assert result["step"] == {"solids": 1, "faces": 7, "valid": True}
    assert result["objects_after_solid_undo"] == ["Part"]

    assert result["objects_after_error"] == ["Part", "Empty"]
    assert result["undo_added_by_error"] == 0
    assert len(result["error_boxes"]) == 1 and "no triangles" in result["error_boxes"][0]
