"""GUI test of Delete, Move and Copy feature (issue 52) in the real FreeCAD window, in one FreeCAD
session under xvfb-run: a plate with a round boss is idealized and made a solid; a face of the boss
is selected, Copy feature opens its group in the task panel (highlighted), an offset previews the
copy, a placement off the plate is refused in the panel, OK copies it in one undo step and
regenerates the solid; undo and redo; then Delete feature removes the copy, and save and reopen
keep both edits. Last, Delete feature on a notch in a block's edge: its group sits across the two
faces of the edge, and deleting it gives the block back.
"""
import json
import math

import pytest

import test_gui as gui

DRIVER = gui.HELPERS + r'''


def state(doc, layer, solid):
    table = json.loads(layer.FeatureTable)
    return {"features": len(table["features"]), "edits": len(json.loads(layer.Edits)) if layer.Edits else 0,
            "volume": solid.Shape.Volume, "valid": solid.Shape.isValid(), "faces": len(solid.Shape.Faces)}


def select_boss_wall(doc, layer):
    table = json.loads(layer.FeatureTable)
    walls = [f["id"] for f in table["features"] if f["type"] == "cylinder"]
    click_wall(layer, walls[0])
    return walls


def click_wall(layer, wall):
    """Select `wall` by a click where it shows in an isometric view; records what was selected."""
    show_only(layer)  # Make B-rep solid showed the solid in its place
    click_feature(isometric_view(), layer, wall)
    result.setdefault("clicked", []).append([wall, selected_features(layer)])


def run():
    if not start_session():
        return
    from PySide import QtCore, QtGui
    import MeshPart, Part

    doc = App.newDocument("Groups")
    plate = Part.makeBox(100, 60, 10).fuse(Part.makeCylinder(8, 15, App.Vector(30, 30, 10))).removeSplitter()
    source = doc.addObject("Mesh::Feature", "Plate")
    source.Mesh = MeshPart.meshFromShape(Shape=plate, MaxLength=2.0)
    doc.recompute()
    layer = run_on(doc, source, "Idealize_SegmentIdealize")[0]
    solid = [o for o in run_on(doc, layer, "Idealize_MakeSolid") if hasattr(o, "IdealizeSolid")][0]
    result["before"] = state(doc, layer, solid)

    select_boss_wall(doc, layer)
    result["layer_visible_before"] = layer.ViewObject.Visibility
    graph = Gui.ActiveDocument.ActiveView.getSceneGraph()
    children = graph.getNumChildren()
    Gui.runCommand("Idealize_CopyFeature")
    wait(0.8)
    form = Gui.getMainWindow().findChild(QtGui.QWidget, "FeatureGroup")
    result["panel_found"] = form is not None
    if form is None:
        return
    combo = Gui.getMainWindow().findChild(QtGui.QDockWidget, "Combo View")
    result["widths"] = {"panel": form.width(), "combo_view": combo.width() if combo is not None else None}
    members = form.findChild(QtGui.QListWidget, "members")
    result["group_text"] = form.findChild(QtGui.QLabel, "group").text()
    result["ticked"] = sum(members.item(i).checkState() == QtCore.Qt.Checked for i in range(members.count()))
    result["highlight_nodes"] = graph.getNumChildren() - children
    form.findChild(QtGui.QDoubleSpinBox, "offsetX").setValue(200.0)
    wait(1.5)
    result["conflict"] = form.findChild(QtGui.QLabel, "status").text()
    form.findChild(QtGui.QDoubleSpinBox, "offsetX").setValue(40.0)
    wait(2.0)
    result["preview"] = form.findChild(QtGui.QLabel, "status").text()
    onto = form.findChild(QtGui.QComboBox, "onto")
    result["onto_choices"] = onto.count()
    onto.setCurrentIndex(1)  # another plane: the boss goes there (or says why it cannot)
    wait(2.0)
    result["onto_status"] = form.findChild(QtGui.QLabel, "status").text()
    onto.setCurrentIndex(0)
    wait(2.0)
    from idealize.gui import task_feature_group
    preview = task_feature_group.active_panel.preview.node
    undo_before = len(doc.UndoNames)
    click_ok()
    wait(1.0)
    result["copied"] = state(doc, layer, solid)
    result["copied"].update({"undo_steps": len(doc.UndoNames) - undo_before,
                             "undo_name": doc.UndoNames[0] if doc.UndoNames else None,
                             "dialog_open": bool(Gui.Control.activeDialog()),
                             "preview_left": graph.findChild(preview) >= 0,
                             "layer_visible": layer.ViewObject.Visibility})
    doc.undo()
    doc.recompute()
    result["undone"] = state(doc, layer, solid)
    doc.redo()
    doc.recompute()
    result["redone"] = state(doc, layer, solid)

    # Delete the copy: its wall is the second cylinder now.
    walls = select_boss_wall(doc, layer)
    click_wall(layer, walls[-1])
    Gui.runCommand("Idealize_DeleteFeature")
    wait(1.5)
    click_ok()
    wait(1.0)
    result["deleted"] = state(doc, layer, solid)
    result["deleted"]["undo_name"] = doc.UndoNames[0] if doc.UndoNames else None

    path = os.path.join(os.path.dirname(CONFIG["result"]), "groups.FCStd")
    doc.saveAs(path)
    name = layer.Name
    App.closeDocument(doc.Name)
    doc = App.openDocument(path)
    import idealize
    reopened = idealize.feature_layer(doc.getObject(name))
    result["reopened"] = {"features": len(reopened.features), "edits": len(json.loads(doc.getObject(name).Edits)),
                          "volume": idealize.make_solid(reopened).volume}
    App.closeDocument(doc.Name)

    # A notch in a block's edge: its group sits across two faces, which meet again when it goes.
    doc = App.newDocument("Notch")
    block = Part.makeBox(60, 40, 20).cut(Part.makeBox(10, 8, 6, App.Vector(25, 0, 14)))
    source = doc.addObject("Mesh::Feature", "Block")
    source.Mesh = MeshPart.meshFromShape(Shape=block, MaxLength=2.0)
    doc.recompute()
    layer = run_on(doc, source, "Idealize_SegmentIdealize")[0]
    solid = [o for o in run_on(doc, layer, "Idealize_MakeSolid") if hasattr(o, "IdealizeSolid")][0]
    result["notch_before"] = state(doc, layer, solid)
    table = json.loads(layer.FeatureTable)
    floor = [f["id"] for f in table["features"] if f["type"] == "plane" and abs(f["params"]["point"][2] - 14) < 1e-6][0]
    click_wall(layer, floor)
    Gui.runCommand("Idealize_DeleteFeature")
    wait(1.5)
    form = Gui.getMainWindow().findChild(QtGui.QWidget, "FeatureGroup")
    members = form.findChild(QtGui.QListWidget, "members")
    result["notch_group_text"] = form.findChild(QtGui.QLabel, "group").text()
    result["notch_ticked"] = sum(members.item(i).checkState() == QtCore.Qt.Checked for i in range(members.count()))
    result["notch_status"] = form.findChild(QtGui.QLabel, "status").text()
    click_ok()
    wait(1.0)
    result["notch_deleted"] = state(doc, layer, solid)
    result["notch_deleted"]["undo_name"] = doc.UndoNames[0] if doc.UndoNames else None
    App.closeDocument(doc.Name)
'''


@pytest.fixture(scope="module")
def groups_run(tmp_path_factory):
    result = gui.run_gui(DRIVER, {}, tmp_path_factory.mktemp("groups"), timeout=300)
    print(json.dumps(result, indent=1))
    assert "exception" not in result, result["exception"]
    assert not result["error_boxes"], result["error_boxes"]
    return result


def boss_volume():
    """The boss plate's volume less the plate's: a cylinder r 8, 15 high (no fillet here)."""
    return math.pi * 64 * 15


def test_the_panel_shows_the_group_and_refuses_a_place_off_the_plate(groups_run):
    assert groups_run["panel_found"]
    widths = groups_run["widths"]  # the panel fits the combo view (its buttons were cut off)
    assert widths["combo_view"] is not None and widths["panel"] <= widths["combo_view"]
    for wall, selected in groups_run["clicked"]:  # every feature was selected by a click on it
        assert selected == [wall]
    assert groups_run["ticked"] >= 2  # the boss's wall and top, and the tessellation's rim facets if any
    assert "on feature" in groups_run["group_text"]
    assert groups_run["highlight_nodes"] == 1  # the highlighted layer replaces the object in the view
    assert groups_run["conflict"].startswith("Cannot apply") and "feature" in groups_run["conflict"]
    assert groups_run["preview"].startswith("Preview")
    assert groups_run["onto_choices"] >= 6  # its own face, and the plate's other five planes
    assert groups_run["onto_status"].startswith(("Preview", "Cannot apply"))


def test_ok_copies_the_boss_in_one_undo_step_and_regenerates_the_solid(groups_run):
    before, copied = groups_run["before"], groups_run["copied"]
    assert copied["features"] == before["features"] + groups_run["ticked"] and copied["edits"] == 1
    assert copied["volume"] == pytest.approx(before["volume"] + boss_volume(), rel=1e-6)
    assert copied["valid"] and copied["faces"] == before["faces"] + 2
    assert copied["undo_steps"] == 1 and copied["undo_name"] == "Copy feature"
    assert not copied["dialog_open"] and not copied["preview_left"]
    assert copied["layer_visible"] == groups_run["layer_visible_before"]


def test_undo_and_redo_restore_the_layer_and_the_solid(groups_run):
    before, undone, redone, copied = (groups_run[k] for k in ("before", "undone", "redone", "copied"))
    for key in ("features", "edits", "volume", "faces"):
        assert undone[key] == pytest.approx(before[key]), key
        assert redone[key] == pytest.approx(copied[key]), key


def test_delete_removes_the_copy_and_both_edits_survive_reopening(groups_run):
    before, deleted, reopened = groups_run["before"], groups_run["deleted"], groups_run["reopened"]
    assert deleted["undo_name"] == "Delete feature"
    assert deleted["features"] == before["features"] and deleted["edits"] == 2
    assert deleted["volume"] == pytest.approx(before["volume"], rel=1e-6) and deleted["valid"]
    assert reopened["edits"] == 2 and reopened["features"] == before["features"]
    assert reopened["volume"] == pytest.approx(before["volume"], rel=1e-6)


def test_delete_feature_takes_a_notch_out_of_an_edge(groups_run):
    before, deleted = groups_run["notch_before"], groups_run["notch_deleted"]
    assert groups_run["notch_ticked"] == 4  # floor, back wall, two side walls
    assert groups_run["notch_group_text"].count("feature") >= 3  # on the block's top and front faces
    assert groups_run["notch_status"].startswith("Preview"), groups_run["notch_status"]
    assert deleted["undo_name"] == "Delete feature" and deleted["edits"] == 1
    assert deleted["features"] == before["features"] - 4
    assert deleted["valid"] and deleted["faces"] == 6
    assert deleted["volume"] == pytest.approx(60 * 40 * 20, rel=1e-6)
