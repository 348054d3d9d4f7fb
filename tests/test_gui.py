"""GUI test: FreeCAD finds the workbench through a symlink in its user Mod folder, and
Idealize_Segment makes a coloured, undoable copy of the selected mesh.

Runs the real FreeCAD GUI under a virtual X server (xvfb-run), with a driver script that
reports back through a JSON file. Skipped when xvfb-run or freecad is missing.
"""
import importlib.util
import json
import os
import shutil

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# A remeshed CAD part from the project's shared test data (never copied into the repository).
SHARED_MESH = os.path.join(os.path.dirname(REPO), "shared", "data", "mesh", "joint.stl")

_SPEC = importlib.util.spec_from_file_location("gui_driver", os.path.join(REPO, "bench", "gui_driver.py"))
gui_driver = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(gui_driver)

# Helpers of the scripts run in FreeCAD's GUI (bench/gui_driver.py), shared with the other GUI
# tests (test_gui_*.py); CONFIG is filled in by the test.
HELPERS = r'''


def wait(seconds):
    """Let the event loop run (timers, the previews) for `seconds`."""
    import time
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        Gui.updateGui()
        time.sleep(0.02)


def click_ok():
    """Press OK in the open task dialog, as a user does."""
    from PySide import QtGui
    for box in Gui.getMainWindow().findChildren(QtGui.QDialogButtonBox):
        ok = box.button(QtGui.QDialogButtonBox.Ok)
        if ok is not None and ok.isVisible():
            ok.click()
            return


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


def start_session():
    """The start of a GUI test's run(): the Mod link (False when FreeCAD must start again to see
    it), error boxes recorded instead of shown (a failing command would block on its modal box),
    and the Idealize workbench active."""
    from PySide import QtGui
    if ensure_link():
        result["restart"] = True  # FreeCAD scans the Mod folders only at start-up
        return False
    result["error_boxes"] = []
    QtGui.QMessageBox.critical = lambda parent, title, text, *rest: result["error_boxes"].append(text)
    Gui.activateWorkbench("IdealizeWorkbench")
    return True


def screenshot_pixels(path):
    """All pixels of a screenshot as (n, 3) RGB ints, and those that are coloured (not white,
    black or grey)."""
    import numpy as np
    from PySide import QtGui
    image = QtGui.QImage(path).convertToFormat(QtGui.QImage.Format_RGB32)
    bgra = np.frombuffer(bytes(image.constBits()), np.uint8).reshape(image.height(), -1, 4)
    rgb = bgra[:, :image.width(), 2::-1].reshape(-1, 3).astype(int)
    return rgb, rgb[rgb.max(axis=1) - rgb.min(axis=1) > 40]


def red_and_colour_counts(path):
    """Screenshot pixels: how many are red, and how many hues (30 degree bins) cover at least
    0.5% of it each; shading changes brightness, not hue, so one colour is one hue."""
    import numpy as np
    from PySide import QtGui
    rgb, coloured = screenshot_pixels(path)
    red, area = 0, {}
    for (r, g, b), n in zip(*(a.tolist() for a in np.unique(coloured, axis=0, return_counts=True))):
        if r > 100 and g < r / 2 and b < r / 2:
            red += n
        else:
            hue = QtGui.QColor(r, g, b).hue() // 30
            area[hue] = area.get(hue, 0) + n
    return red, sum(n >= 0.005 * len(rgb) for n in area.values())


def dominant_hue(path):
    """Hue (degrees, 30 degree bins) that covers most of the coloured pixels of a screenshot."""
    from PySide import QtGui
    _, coloured = screenshot_pixels(path)
    hues = [QtGui.QColor(*map(int, c)).hue() // 30 * 30 for c in coloured[::7]]
    return max(set(hues), key=hues.count) if hues else None


def type_color_counts(colors):
    """{surface type: facets} of per-facet colours in the thesis palette ("other": anything else)."""
    from idealize.freecad.mesh import SURFACE_COLORS
    palette = {tuple(round(c, 2) for c in rgb): t for t, rgb in SURFACE_COLORS.items()}
    seen = {}
    for c in colors:
        t = palette.get(tuple(round(x, 2) for x in c[:3]), "other")
        seen[t] = seen.get(t, 0) + 1
    return seen


def shoot(key):
    """Isometric screenshot of the whole scene, without selection highlight."""
    Gui.Selection.clearSelection()
    view = Gui.ActiveDocument.ActiveView
    view.viewIsometric()
    view.fitAll()
    Gui.updateGui()
    view.saveImage(CONFIG[key], 800, 600, "White")


def isometric_view():
    """The active 3D view turned isometric and fitted, with nothing selected: where tests click."""
    Gui.Selection.clearSelection()
    view = Gui.ActiveDocument.ActiveView
    view.viewIsometric()
    view.fitAll()
    wait(0.3)
    return view


def show_only(obj):
    """Show `obj` alone in the view, as a user does (Space on the tree's items) to click on it."""
    for other in obj.Document.Objects:
        if other.ViewObject is not None and other is not obj:
            other.ViewObject.Visibility = False
    obj.ViewObject.Visibility = True


def selected_features(layer):
    """The features of the layer's facets that are selected (what a click selected)."""
    labels = layer.Labels
    return sorted({labels[int(name[len("Facet"):])] for entry in Gui.Selection.getSelectionEx()
                   if entry.Object == layer for name in entry.SubElementNames if name.startswith("Facet")})


def run_on(doc, obj, command):
    """Run a command with obj selected; the objects it added. Records, per run, how many objects
    it added and what it left selected in result["selected_after"][command]."""
    Gui.Selection.clearSelection()
    Gui.Selection.addSelection(obj)
    names = {o.Name for o in doc.Objects}
    Gui.runCommand(command)
    Gui.updateGui()
    new = [o for o in doc.Objects if o.Name not in names]
    result.setdefault("selected_after", {}).setdefault(command, []).append(
        [len(new), [o.Label for o in Gui.Selection.getSelection()]])
    return new


def report_view_text():
    """Everything the report view shows (messages, warnings, errors and tracebacks)."""
    from PySide import QtGui
    views = [w for w in Gui.getMainWindow().findChildren(QtGui.QTextEdit) if w.objectName() == "Report view"]
    return views[0].toPlainText() if views else ""


def first_visible(kind, label=""):
    """The first visible top-level widget of a Qt class whose label text contains `label`."""
    from PySide import QtGui
    for widget in QtGui.QApplication.topLevelWidgets():
        if isinstance(widget, kind) and widget.isVisible() and label in getattr(widget, "labelText", str)():
            return widget
    return None
''' + gui_driver.MOUSE  # clicks and drags at pixel positions, as a user makes them

# The script run() in FreeCAD's GUI.
DRIVER = HELPERS + r'''

def run():
    if ensure_link():
        result["restart"] = True  # FreeCAD scans the Mod folders only at start-up
        return
    result["workbenches"] = sorted(Gui.listWorkbenches())
    if "IdealizeWorkbench" not in result["workbenches"]:
        return

    from PySide import QtCore, QtGui
    import Mesh, Part, MeshPart
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

    # Segment & Idealize: a feature layer object coloured by type, undone in one step.
    new = run_on(doc, source, "Idealize_SegmentIdealize")
    result["idealize_labels"] = [o.Label for o in new]
    result["idealize_undo_name"] = doc.UndoNames[0] if doc.UndoNames else None
    if new:
        layer = new[0]
        result["layer"] = {"type": layer.TypeId, "source": layer.Source.Name, "labels": len(layer.Labels),
                           "features": layer.Features, "facets": layer.Mesh.CountFacets,
                           "color_by": layer.ViewObject.ColorBy, "coloring": layer.ViewObject.Coloring,
                           "touched": "Touched" in layer.State, "proxy": type(layer.Proxy).__name__}
        result["idealize_type_colors"] = type_color_counts(layer.FaceColors)
        shoot("screenshot_types")
        result["hue_types"] = dominant_hue(CONFIG["screenshot_types"])
        # One undo removes the layer (and shows the source again); redo brings it back whole.
        name, labels = layer.Name, list(layer.Labels)
        doc.undo()
        result["after_layer_undo"] = [[o.Label for o in doc.Objects], source.ViewObject.Visibility]
        doc.redo()
        layer = doc.getObject(name)
        result["after_layer_redo"] = layer is not None and list(layer.Labels) == labels
        # Colour by feature: one colour per feature.
        layer.ViewObject.ColorBy = "Feature"
        result["feature_colors"] = len(set(layer.FaceColors))
        # Deviation map through its command: colours from the deviation scale and a legend.
        Gui.Selection.clearSelection()
        Gui.Selection.addSelection(layer)
        result["deviation_active"] = Gui.isCommandActive("Idealize_DeviationMap")
        Gui.runCommand("Idealize_DeviationMap")
        Gui.updateGui()
        result["deviation_mode"] = layer.ViewObject.ColorBy
        result["deviation_colors"] = len(set(layer.FaceColors))
        legend = layer.ViewObject.Proxy.legend
        result["legend_shown"] = legend is not None and legend.node.whichChild.getValue() != -1
        shoot("screenshot_deviation")
        result["hue_deviation"] = dominant_hue(CONFIG["screenshot_deviation"])
        layer.ViewObject.ColorBy = "Type"
        result["legend_after_type"] = legend.node.whichChild.getValue() != -1 if legend else None

        # The task panel (double-click): the table, row <-> facet selection, the options section.
        Gui.Selection.clearSelection()
        Gui.ActiveDocument.setEdit(layer.Name)
        Gui.updateGui()
        panel = layer.ViewObject.Proxy.panel
        table = panel.form.features
        result["panel"] = {"rows": table.rowCount(), "columns": table.columnCount(),
                           "types": sorted({table.item(r, 1).text() for r in range(table.rowCount())}),
                           "options_hidden": not panel.form.options.isVisible(),
                           "summary": panel.form.summary.text()}
        cylinder_row = [r for r in range(table.rowCount()) if table.item(r, 1).text() == "cylinder"][0]
        table.selectRow(cylinder_row)
        Gui.updateGui()
        cylinder = int(table.item(cylinder_row, 0).text())
        labels = list(layer.Labels)
        base = type_color_counts(layer.FaceColors)
        result["highlight"] = {"cylinder_facets": labels.count(cylinder), "bright": base}
        panel.form.grab().save(CONFIG["screenshot_panel"])
        # A click on a plane in the view selects that plane's row.
        view = isometric_view()
        planes = [int(table.item(r, 0).text()) for r in range(table.rowCount()) if table.item(r, 1).text() == "plane"]
        clicked = next((p for p in planes if click_feature(view, layer, p) is not None), None)
        Gui.updateGui()
        rows = table.selectionModel().selectedRows()
        result["row_of_facet"] = [int(table.item(rows[0].row(), 0).text()) if rows else None, clicked]
        panel.form.optionsToggle.setChecked(True)
        result["options_shown"] = panel.form.options.isVisible()
        panel.reject()
        Gui.updateGui()
        result["panel_closed"] = layer.ViewObject.Proxy.panel is None
        result["colors_after_panel"] = type_color_counts(layer.FaceColors)

        # The console API on the document object.
        import idealize
        solid = idealize.make_solid(layer)
        result["api_solid"] = [bool(solid.solid), solid.faces]

        # Save and reopen: the layer comes back as it was, without recomputing.
        before = {"labels": list(layer.Labels), "table": layer.FeatureTable, "colors": len(layer.FaceColors)}
        doc.saveAs(CONFIG["fcstd"])
        App.closeDocument(doc.Name)
        doc = App.openDocument(CONFIG["fcstd"])
        layer = doc.getObject(name)
        source = doc.getObject("Part")
        result["reopened"] = {"labels": list(layer.Labels) == before["labels"],
                              "table": layer.FeatureTable == before["table"],
                              "colors": len(layer.FaceColors) == before["colors"],
                              "proxy": type(layer.Proxy).__name__, "view": type(layer.ViewObject.Proxy).__name__,
                              "touched": "Touched" in layer.State, "source": layer.Source.Name}
        result["reopened_solid"] = idealize.make_solid(layer).faces
        made = run_on(doc, layer, "Idealize_MakeSolid")
        result["solid_from_layer"] = sorted(o.Label for o in made)
        doc.undo()
        # Editing the source recomputes the layer.
        moved = source.Mesh.copy()
        moved.translate(5, 0, 0)
        source.Mesh = moved
        doc.recompute()
        result["recomputed"] = {"touched": "Touched" in layer.State,
                                "x_min": layer.Mesh.BoundBox.XMin, "labels": len(layer.Labels)}
        App.closeDocument(doc.Name)
        doc = App.openDocument(CONFIG["fcstd"])
        source = doc.getObject("Part")
        doc.removeObject(name)
        doc.recompute()
        source.ViewObject.Visibility = True
    else:
        doc.undo()
    result["objects_after_idealize"] = [o.Label for o in doc.Objects]

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

    # Cancel: a long Segment & Idealize shows its progress, and Cancel leaves the document as it was.
    big = doc.addObject("Mesh::Feature", "Big")
    big.Mesh = Mesh.createSphere(10, 450)
    doc.recompute()
    undo_count = len(doc.UndoNames)
    seen = {"visible": False, "fraction": 0}

    def press_cancel():
        for widget in QtGui.QApplication.topLevelWidgets():
            if isinstance(widget, QtGui.QProgressDialog) and widget.isVisible():
                seen["visible"], seen["fraction"] = True, widget.value()
                seen["label"] = widget.labelText()
                widget.findChild(QtGui.QPushButton).click()  # as the user does
                return
        QtCore.QTimer.singleShot(100, press_cancel)

    QtCore.QTimer.singleShot(700, press_cancel)
    new = run_on(doc, big, "Idealize_SegmentIdealize")
    result["cancel"] = {"new": [o.Label for o in new], "undo_added": len(doc.UndoNames) - undo_count,
                        "status": Gui.getMainWindow().statusBar().currentMessage(), **seen}
    doc.removeObject("Big")
    doc.recompute()

    # A real mesh from the shared test data, read as a user would (File > Import).
    import Mesh as MeshModule
    MeshModule.insert(CONFIG["shared_mesh"], doc.Name)
    joint = doc.Objects[-1]
    new = run_on(doc, joint, "Idealize_SegmentIdealize")
    if new:
        result["shared"] = {"facets": joint.Mesh.CountFacets, "labels": len(new[0].Labels),
                            "features": new[0].Features, "types": sorted(type_color_counts(new[0].FaceColors))}
    doc.removeObject(joint.Name)
    for obj in new:
        doc.removeObject(obj.Name)
    doc.recompute()

    # Bad input of every class through Segment & Idealize: a clear error (box, report view) and an
    # untouched document, or a layer whose panel names the repair; FreeCAD never goes down.
    from idealize.freecad.layer_object import freecad_mesh as exact_mesh
    box = MeshPart.meshFromShape(Shape=Part.makeBox(30, 20, 10), MaxLength=2.0)
    points, facets = box.Topology
    V = [[p.x, p.y, p.z] for p in points]
    F = [list(f) for f in facets]
    far = [[x + 1e9, y, z] for x, y, z in V]
    half_flipped = [f[::-1] if i % 2 else f for i, f in enumerate(F)]
    shifted = [[x + 15, y + 10, z + 5] for x, y, z in V]
    cases = {"nan": ([[float("nan"), y, z] if i == 0 else [x, y, z] for i, (x, y, z) in enumerate(V)], F),
             "collapsed": ([[1e-12 * c for c in p] for p in V], F),
             "far_from_origin": (far, F),
             "flipped": (V, half_flipped),
             "open": (V, F[:-6]),
             "self_intersecting": (V + shifted, F + [[i + len(V) for i in f] for f in F])}
    result["bad_input"] = {}
    for name, (points, faces) in cases.items():
        obj = doc.addObject("Mesh::Feature", "Bad_" + name)
        obj.Mesh = exact_mesh(points, faces)
        doc.recompute()
        boxes = len(result["error_boxes"])
        undo_count = len(doc.UndoNames)
        new = run_on(doc, obj, "Idealize_SegmentIdealize")
        outcome = {"new": len(new), "undo_added": len(doc.UndoNames) - undo_count,
                   "error": result["error_boxes"][boxes:]}
        if new:
            import json as _json
            outcome["check"] = _json.loads(new[0].FeatureTable)["mesh_check"]
            outcome["features"] = new[0].Features
        result["bad_input"][name] = outcome
        for o in new + [obj]:
            doc.removeObject(o.Name)
        doc.recompute()

    # A mesh the core rejects: the transaction is aborted and the error is shown.
    empty = doc.addObject("Mesh::Feature", "Empty")
    doc.recompute()
    undo_count = len(doc.UndoNames)
    Gui.Selection.clearSelection()
    Gui.Selection.addSelection(empty)
    Gui.runCommand("Idealize_Segment")
    result["objects_after_error"] = [o.Label for o in doc.Objects]
    result["undo_added_by_error"] = len(doc.UndoNames) - undo_count

'''


def run_gui(driver, config, tmp_path, timeout=240):
    """Run a driver script (HELPERS + its run()) in FreeCAD's GUI under xvfb-run; its result dict.
    Skips when the tools are missing. The first run after the user Mod link was (re)created only
    creates it: FreeCAD scans the Mod folders at start-up, so it runs a second time."""
    for tool in ("xvfb-run", "freecad", "timeout"):
        if shutil.which(tool) is None:
            pytest.skip("%s is not installed; the GUI test runs FreeCAD under xvfb-run" % tool)
    if "libasan" in os.environ.get("LD_PRELOAD", "") and os.environ.get("SANITIZE_GUI") != "1":
        pytest.skip("tools/sanitize.sh: FreeCAD loads the workbench through its Mod link, not this sanitized "
                    "build (SANITIZE_GUI=1 runs it anyway)")
    for attempt in (1, 2):
        config = dict(config, repo=REPO, result=str(tmp_path / ("result%d.json" % attempt)))
        try:
            result = gui_driver.run_in_freecad_gui(driver, config, tmp_path / ("driver%d.py" % attempt), timeout)
        except gui_driver.DriverError as error:
            pytest.fail(str(error))
        if not result.get("restart"):
            break
    assert not result.get("restart"), "FreeCAD did not pick up the new link %s" % result["link"]
    return result


@pytest.fixture(scope="module")
def gui_result(tmp_path_factory):
    """One run of the driver in FreeCAD's GUI; the tests below each check a part of what it saw, so
    that one failure does not hide the rest."""
    tmp_path = tmp_path_factory.mktemp("gui")
    assert os.path.exists(SHARED_MESH), "the shared test data must sit beside the repository: %s" % SHARED_MESH
    config = {"screenshot": str(tmp_path / "segment-gui.png"),
              "screenshot_types": str(tmp_path / "idealize-gui.png"),
              "screenshot_deviation": str(tmp_path / "deviation-gui.png"),
              "screenshot_panel": str(tmp_path / "panel-gui.png"), "fcstd": str(tmp_path / "layer.FCStd"),
              "shared_mesh": SHARED_MESH,
              "screenshot_solid": str(tmp_path / "solid-gui.png"), "step": str(tmp_path / "part.step")}
    result = run_gui(DRIVER, config, tmp_path)
    print(json.dumps(result, indent=1))
    return result


def test_the_workbench_loads_from_this_checkout(gui_result):
    """FreeCAD lists the workbench, activates it, and imports idealize from this repository."""
    result = gui_result
    assert "exception" not in result, result["exception"]
    assert "IdealizeWorkbench" in result["workbenches"], "FreeCAD does not list the workbench"
    assert result["active_workbench"] == "IdealizeWorkbench"
    assert result["idealize_file"].startswith(os.path.realpath(REPO) + os.sep)


def test_segment_command(gui_result):
    """Segment adds a coloured copy in one undo step, leaves the source as it was, and nothing
    selected."""
    result = gui_result
    assert "exception" not in result, result["exception"]
    assert result["active_without_selection"] is False
    assert result["active_with_selection"] is True
    assert result["new_labels"] == ["Part_Segmented"]
    assert result["source_after"] == result["source_before"]
    assert result["undo_names"][0] == "Segment mesh"
    assert "patches" in result["status_message"]
    # Every command that added something left nothing selected (the highlight would hide its colours).
    runs = [(command, run) for command, runs in result["selected_after"].items() for run in runs if run[0]]
    assert {command for command, _ in runs} >= {"Idealize_Segment", "Idealize_SegmentIdealize", "Idealize_MakeSolid"}
    assert all(selected == [] for _, (_, selected) in runs), runs

    assert result["face_colors"] == result["facets"] == result["source_before"][1]
    assert result["distinct_face_colors"] >= 4  # several patches plus red transitions
    assert result["coloring"] is True
    assert result["source_visible"] is False
    # Transition triangles are thin slivers along the edges: few, but some, red pixels.
    assert result["red_pixels"] > 20, "no red transitions in the screenshot"
    assert result["hues"] >= 3, "patch colours do not show in the screenshot"

    assert result["objects_after_undo"] == ["Part"]
    assert result["source_visible_after_undo"] is True


def test_segment_and_idealize_makes_a_feature_layer(gui_result):
    """Segment & Idealize: the layer, its colours by type, feature and deviation, undo and redo."""
    result = gui_result
    assert "exception" not in result, result["exception"]
    # Box with a hole: a feature layer with 6 planes (light green) and the hole's cylinder (yellow).
    assert result["idealize_labels"] == ["Part_Layer"]
    assert result["idealize_undo_name"] == "Segment and idealize mesh"
    layer = result["layer"]
    assert layer["type"] == "Mesh::FeaturePython" and layer["proxy"] == "FeatureLayerObject"
    assert layer["source"] == "Part" and layer["labels"] == layer["facets"] == result["source_before"][1]
    assert layer["features"] == 7 and layer["color_by"] == "Type" and layer["coloring"] is True
    assert layer["touched"] is False
    colors = result["idealize_type_colors"]
    assert set(colors) == {"plane", "cylinder"}, colors
    assert sum(colors.values()) == result["source_before"][1]
    assert result["after_layer_undo"] == [["Part"], True]
    assert result["after_layer_redo"] is True
    assert result["feature_colors"] == 7
    assert result["deviation_active"] is True and result["deviation_mode"] == "Deviation"
    assert result["deviation_colors"] >= 1
    # What the view shows: light green planes by type; by deviation (an exact tessellation: all
    # vertices on their surfaces) the blue of zero.
    assert result["hue_types"] in (90, 120), result["hue_types"]
    assert result["hue_deviation"] in (210, 240), result["hue_deviation"]
    assert result["legend_shown"] is True and result["legend_after_type"] is False


def test_task_panel(gui_result):
    """The layer's task panel: its table, summary, highlight and row selection."""
    result = gui_result
    assert "exception" not in result, result["exception"]
    panel = result["panel"]
    assert panel["rows"] == 7 and panel["columns"] == 3 and panel["types"] == ["cylinder", "plane"]
    assert panel["options_hidden"] is True and result["options_shown"] is True
    assert "Mesh: 1 shell, closed, 0 self-intersecting triangle pairs; repaired: nothing needed" in panel["summary"]
    # Selecting the cylinder's row leaves its facets in their colour and dims all others.
    highlight = result["highlight"]
    assert highlight["bright"] == {"cylinder": highlight["cylinder_facets"],
                                   "other": result["source_before"][1] - highlight["cylinder_facets"]}
    assert result["row_of_facet"][1] is not None, "no plane could be clicked"
    assert result["row_of_facet"][0] == result["row_of_facet"][1]
    assert result["panel_closed"] is True
    assert result["colors_after_panel"] == result["idealize_type_colors"]


def test_layer_saves_reopens_and_recomputes(gui_result):
    """The layer as a document object: make_solid takes it, it survives save and reopen, and
    recomputes when its source moves."""
    result = gui_result
    assert "exception" not in result, result["exception"]
    assert result["api_solid"] == [True, 7]
    reopened = result["reopened"]
    assert reopened == {"labels": True, "table": True, "colors": True, "proxy": "FeatureLayerObject",
                        "view": "ViewProviderFeatureLayer", "touched": False, "source": "Part"}
    assert result["reopened_solid"] == 7
    assert {"Part_Solid", "Part_Primitives"} <= set(result["solid_from_layer"])
    recomputed = result["recomputed"]
    assert recomputed["touched"] is False and abs(recomputed["x_min"] - 5.0) < 1e-6
    assert recomputed["labels"] == result["source_before"][1]
    assert result["objects_after_idealize"] == ["Part"]


def test_a_real_mesh_gets_a_layer(gui_result):
    """A real remeshed CAD part read as a user would (File > Import) gets its layer."""
    result = gui_result
    assert "exception" not in result, result["exception"]
    shared = result["shared"]
    assert shared["labels"] == shared["facets"] > 20000 and shared["features"] >= 5
    assert {"plane", "cylinder"} <= set(shared["types"]), shared


def test_cancel_leaves_the_document_as_it_was(gui_result):
    """Cancel during a long run: a progress dialog, nothing added, no undo step."""
    result = gui_result
    assert "exception" not in result, result["exception"]
    cancel = result["cancel"]
    assert cancel["visible"] is True, "no progress dialog during a long run"
    assert cancel["new"] == [] and cancel["undo_added"] == 0
    assert "cancelled" in cancel["status"]


def test_make_solid_and_export_step(gui_result):
    """Make B-rep solid: a valid coloured solid with its primitives in one undo step, exported to
    STEP."""
    result = gui_result
    assert "exception" not in result, result["exception"]
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


def test_bad_input_gives_clear_errors_and_no_undo_step(gui_result):
    """Bad meshes: a message naming the problem, no object and no undo step; repairable ones
    work."""
    result = gui_result
    assert "exception" not in result, result["exception"]
    bad = result["bad_input"]
    for name, words in (("nan", "NaN"), ("collapsed", "collapsed"), ("far_from_origin", "origin")):
        assert bad[name]["new"] == 0 and bad[name]["undo_added"] == 0, (name, bad[name])
        assert len(bad[name]["error"]) == 1 and words in bad[name]["error"][0], (name, bad[name])
    assert bad["flipped"]["check"]["flipped_faces_repaired"] > 0 and bad["flipped"]["features"] == 6
    assert bad["open"]["check"]["boundary_loops"] == 1 and not bad["open"]["error"]
    assert bad["self_intersecting"]["check"]["self_intersecting_pairs"] > 0 and bad["self_intersecting"]["check"]["shells"] == 2

    assert result["objects_after_error"] == ["Part", "Empty"]
    assert result["undo_added_by_error"] == 0
    assert len(result["error_boxes"]) == 4 and "no triangles" in result["error_boxes"][-1]
