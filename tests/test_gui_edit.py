"""GUI test of Push/Pull (issue 51) in the real FreeCAD window, in one FreeCAD session under
xvfb-run: a generated plate with a hole is idealized and made a solid; its top face is selected and
pulled through the task panel (a preview while the value changes), OK is one undo step that edits
the layer and regenerates the solid; undo and redo; save and reopen keep the edited layer.
"""
import json

import pytest

import test_gui as gui

DRIVER = gui.HELPERS + r'''


def layer_state(doc, layer, solid):
    table = json.loads(layer.FeatureTable)
    top = table["features"][CONFIG_TOP[0]]["params"]["point"][2] if CONFIG_TOP else None
    primitives = doc.getObject("Plate_Primitives")
    return {"top": top, "edits": len(json.loads(layer.Edits)) if layer.Edits else 0,
            "volume": solid.Shape.Volume, "valid": solid.Shape.isValid(), "facets": layer.Mesh.CountFacets,
            "primitives_top": max(o.Shape.BoundBox.ZMax for o in primitives.Group)}


CONFIG_TOP = []


def run():
    if not start_session():
        return
    from PySide import QtGui
    import MeshPart, Part

    doc = App.newDocument("PushPull")
    plate = Part.makeBox(60, 40, 20).cut(Part.makeCylinder(6, 20, App.Vector(20, 20, 0)))
    source = doc.addObject("Mesh::Feature", "Plate")
    source.Mesh = MeshPart.meshFromShape(Shape=plate, MaxLength=2.0)
    doc.recompute()
    layer = run_on(doc, source, "Idealize_SegmentIdealize")[0]
    solid = [o for o in run_on(doc, layer, "Idealize_MakeSolid") if hasattr(o, "IdealizeSolid")][0]
    table = json.loads(layer.FeatureTable)
    top = [f["id"] for f in table["features"] if f["type"] == "plane" and f["params"]["normal"][2] > 0.99
           and abs(f["params"]["point"][2] - 20) < 1e-6][0]
    CONFIG_TOP.append(top)
    result["top"] = [top]
    result["before"] = layer_state(doc, layer, solid)

    # A click on the top face in the view selects it; the command works on its feature.
    show_only(layer)  # Make B-rep solid showed the solid in its place
    view = isometric_view()
    result["push_pull_active_before_click"] = Gui.Command.get("Idealize_PushPull").isActive()
    shots = [os.path.join(os.path.dirname(CONFIG["result"]), name) for name in ("unselected.png", "selected.png")]
    view.saveImage(shots[0], 400, 300, "Current")
    result["clicked"] = click_feature(view, layer, top) is not None
    result["selected_feature"] = selected_features(layer)
    view.saveImage(shots[1], 400, 300, "Current")
    # The selection shows on the clicked feature's faces, not on the whole layer.
    import numpy as np
    (before, coloured), (after, _) = screenshot_pixels(shots[0]), screenshot_pixels(shots[1])
    part = (before.max(axis=1) - before.min(axis=1)) > 40
    result["highlighted_share"] = float((np.abs(after - before).sum(axis=1) > 30)[part].mean())
    result["highlight_shown"] = list(layer.ViewObject.Proxy.highlight.shown["sel"])
    result["layer_visible_before"] = layer.ViewObject.Visibility
    graph = Gui.ActiveDocument.ActiveView.getSceneGraph()
    children = graph.getNumChildren()
    Gui.runCommand("Idealize_PushPull")
    wait(0.3)
    result["dialog_open"] = bool(Gui.Control.activeDialog())
    form = Gui.getMainWindow().findChild(QtGui.QWidget, "PushPull")
    result["panel_found"] = form is not None
    if form is None:
        return
    result["feature_text"] = form.findChild(QtGui.QLabel, "feature").text()
    result["arrow_nodes"] = graph.getNumChildren() - children
    # Dragging the arrow pulls the face: its offset shows in the panel.
    from idealize.gui import task_push_pull
    arrow = task_push_pull.active_panel.dragger
    arrow.dragger.translation.setValue(3.0 / arrow.size, 0.0, 0.0)
    wait(0.5)
    result["dragged_value"] = form.findChild(QtGui.QDoubleSpinBox, "value").value()
    form.findChild(QtGui.QDoubleSpinBox, "value").setValue(5.0)
    wait(1.5)
    result["preview"] = {"status": form.findChild(QtGui.QLabel, "status").text(),
                         "added_nodes": graph.getNumChildren() - children,
                         "layer_hidden": not layer.ViewObject.Visibility}
    # A value no configuration satisfies: the panel says so, the preview goes.
    form.findChild(QtGui.QDoubleSpinBox, "value").setValue(-30.0)
    wait(1.5)
    result["conflict"] = {"status": form.findChild(QtGui.QLabel, "status").text(),
                          "added_nodes": graph.getNumChildren() - children}
    # OK on it: refused with a message, the panel stays, and the document has no new undo step.
    undo_refused, boxes = len(doc.UndoNames), len(result["error_boxes"])
    click_ok()
    wait(0.5)
    result["refused_ok"] = {"undo_steps": len(doc.UndoNames) - undo_refused, "boxes": result["error_boxes"][boxes:],
                            "dialog_open": bool(Gui.Control.activeDialog())}
    del result["error_boxes"][boxes:]
    form.findChild(QtGui.QDoubleSpinBox, "value").setValue(5.0)
    wait(1.5)
    undo_before = len(doc.UndoNames)
    click_ok()
    wait(0.5)
    result["after"] = layer_state(doc, layer, solid)
    result["after"].update({"dialog_open": bool(Gui.Control.activeDialog()), "undo_steps": len(doc.UndoNames) - undo_before,
                            "undo_name": doc.UndoNames[0] if doc.UndoNames else None,
                            "layer_visible": layer.ViewObject.Visibility,
                            "added_nodes": graph.getNumChildren() - children})
    doc.undo()
    doc.recompute()
    result["undone"] = layer_state(doc, layer, solid)
    doc.redo()
    doc.recompute()
    result["redone"] = layer_state(doc, layer, solid)
    path = os.path.join(os.path.dirname(CONFIG["result"]), "pushpull.FCStd")
    doc.saveAs(path)
    name = layer.Name
    App.closeDocument(doc.Name)
    doc = App.openDocument(path)
    layer = doc.getObject(name)
    import idealize
    reopened = idealize.feature_layer(layer)
    result["reopened"] = {"top": reopened.features[top]["params"]["point"][2], "edits": len(json.loads(layer.Edits)),
                          "volume": idealize.make_solid(reopened).volume}
    App.closeDocument(doc.Name)
'''

# The plate 60 x 40 x 20 less a hole of radius 6 through it, and pulled up by 5.
VOLUME = 60 * 40 * 20 - 3.141592653589793 * 36 * 20
PULLED = VOLUME * 25 / 20


@pytest.fixture(scope="module")
def push_pull_run(tmp_path_factory):
    result = gui.run_gui(DRIVER, {}, tmp_path_factory.mktemp("pushpull"), timeout=300)
    print(json.dumps(result, indent=1))
    assert "exception" not in result, result["exception"]
    assert not result["error_boxes"], result["error_boxes"]
    return result


def test_dragging_the_arrow_sets_the_offset(push_pull_run):
    assert push_pull_run["dragged_value"] == pytest.approx(3.0, abs=1e-3)


def test_a_click_on_the_face_selects_its_feature_and_enables_the_command(push_pull_run):
    assert not push_pull_run["push_pull_active_before_click"]
    assert push_pull_run["clicked"]
    assert push_pull_run["selected_feature"] == push_pull_run["top"]
    # The top face's share of the part's pixels in an isometric view, not all of them (FreeCAD's
    # mesh view highlights the whole object) and not none.
    assert push_pull_run["highlight_shown"] == push_pull_run["top"]
    assert 0.1 < push_pull_run["highlighted_share"] < 0.8


def test_the_command_opens_the_panel_on_the_selected_face(push_pull_run):
    assert push_pull_run["dialog_open"] and push_pull_run["panel_found"]
    assert ", plane: normal (0, 0, 1), offset 20" in push_pull_run["feature_text"]


def test_the_panel_previews_the_edit_and_names_a_conflict(push_pull_run):
    preview = push_pull_run["preview"]
    assert push_pull_run["arrow_nodes"] == 1  # the arrow on the picked face
    assert preview["status"].startswith("Preview") and preview["added_nodes"] == 2 and preview["layer_hidden"]
    conflict = push_pull_run["conflict"]
    assert conflict["status"].startswith("Cannot apply") and "feature" in conflict["status"]
    assert conflict["added_nodes"] == 1  # the preview went, the arrow stays


def test_a_refused_ok_keeps_the_panel_and_adds_no_undo_step(push_pull_run):
    refused = push_pull_run["refused_ok"]
    assert refused["undo_steps"] == 0 and refused["dialog_open"]
    assert len(refused["boxes"]) == 1 and "feature" in refused["boxes"][0]


def test_ok_edits_the_layer_and_regenerates_the_solid_in_one_undo_step(push_pull_run):
    before, after = push_pull_run["before"], push_pull_run["after"]
    assert before["top"] == pytest.approx(20.0) and before["volume"] == pytest.approx(VOLUME, rel=1e-3)
    assert after["top"] == pytest.approx(25.0, abs=1e-4) and after["edits"] == 1
    assert after["volume"] == pytest.approx(PULLED, rel=1e-3) and after["valid"]
    assert before["primitives_top"] == pytest.approx(20.0, abs=1e-4)
    assert after["primitives_top"] == pytest.approx(25.0, abs=1e-4)  # the primitives follow
    assert after["undo_steps"] == 1 and after["undo_name"] == "Push/Pull"
    # The panel closed, its preview gone, and the layer shown as it was before.
    assert not after["dialog_open"] and after["added_nodes"] == 0  # no preview, no arrow left
    assert after["layer_visible"] == push_pull_run["layer_visible_before"]


def test_undo_and_redo_restore_the_layer_and_the_solid(push_pull_run):
    before, undone, redone, after = (push_pull_run[k] for k in ("before", "undone", "redone", "after"))
    for key in ("top", "edits", "volume", "facets", "primitives_top"):
        assert undone[key] == pytest.approx(before[key]), key
        assert redone[key] == pytest.approx(after[key]), key


def test_the_edited_layer_survives_save_and_reopen(push_pull_run):
    reopened = push_pull_run["reopened"]
    assert reopened["edits"] == 1 and reopened["top"] == pytest.approx(25.0, abs=1e-4)
    assert reopened["volume"] == pytest.approx(PULLED, rel=1e-3)
