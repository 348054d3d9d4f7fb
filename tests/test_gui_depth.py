"""GUI test of a hole's depth in the Push/Pull panel (issue 52) in the real FreeCAD window under
xvfb-run: a plate with a blind hole is idealized and made a solid; the hole's wall is selected,
Push/Pull offers its depth (6 mm now), 25 mm previews a through hole, OK makes it in one undo step
and regenerates the solid, and undo brings the blind hole back.
"""
import json
import math

import pytest

import test_gui as gui

DRIVER = gui.HELPERS + r'''


def run():
    if not start_session():
        return
    from PySide import QtGui
    import MeshPart, Part

    doc = App.newDocument("Depth")
    plate = Part.makeBox(60, 40, 10).cut(Part.makeCylinder(4, 6, App.Vector(30, 20, 4)))
    source = doc.addObject("Mesh::Feature", "Plate")
    source.Mesh = MeshPart.meshFromShape(Shape=plate, MaxLength=2.0)
    doc.recompute()
    layer = run_on(doc, source, "Idealize_SegmentIdealize")[0]
    solid = [o for o in run_on(doc, layer, "Idealize_MakeSolid") if hasattr(o, "IdealizeSolid")][0]
    result["before"] = {"volume": solid.Shape.Volume, "faces": len(solid.Shape.Faces)}
    table = json.loads(layer.FeatureTable)
    wall = [f["id"] for f in table["features"] if f["type"] == "cylinder"][0]
    result["wall"] = wall
    # A click on the hole's wall in the solid Make B-rep solid shows: the command edits its feature.
    view = isometric_view()
    result["solid_visible"] = solid.ViewObject.Visibility and not layer.ViewObject.Visibility
    result["clicked"] = click_face(view, solid, list(solid.IdealizeFaceFeatures).index(wall)) is not None
    result["push_pull_active"] = Gui.Command.get("Idealize_PushPull").isActive()
    Gui.runCommand("Idealize_PushPull")
    wait(0.5)
    form = Gui.getMainWindow().findChild(QtGui.QWidget, "PushPull")
    result["panel_found"] = form is not None
    if form is None:
        return
    choice = form.findChild(QtGui.QComboBox, "parameter")
    texts = [choice.itemText(i) for i in range(choice.count())]
    result["choices"] = texts
    choice.setCurrentIndex([i for i, t in enumerate(texts) if t.startswith("Hole depth")][0])
    wait(0.5)
    value = form.findChild(QtGui.QDoubleSpinBox, "value")
    result["depth_shown"] = value.value()
    value.setValue(25.0)
    wait(2.0)
    result["preview"] = form.findChild(QtGui.QLabel, "status").text()
    result["solid_hidden_in_preview"] = not solid.ViewObject.Visibility
    click_ok()
    wait(1.0)
    result["through"] = {"volume": solid.Shape.Volume, "faces": len(solid.Shape.Faces), "valid": solid.Shape.isValid(),
                         "undo_name": doc.UndoNames[0] if doc.UndoNames else None,
                         "solid_visible": solid.ViewObject.Visibility}
    doc.undo()
    doc.recompute()
    result["undone"] = {"volume": solid.Shape.Volume, "faces": len(solid.Shape.Faces)}
'''


@pytest.fixture(scope="module")
def depth_run(tmp_path_factory):
    result = gui.run_gui(DRIVER, {}, tmp_path_factory.mktemp("depth"), timeout=300)
    print(json.dumps(result, indent=1))
    assert "exception" not in result, result["exception"]
    assert not result["error_boxes"], result["error_boxes"]
    return result


def test_push_pull_offers_a_hole_depth_and_makes_it_through_in_one_undo_step(depth_run):
    assert depth_run["solid_visible"] and depth_run["clicked"] and depth_run["push_pull_active"]
    assert depth_run["panel_found"]
    assert depth_run["depth_shown"] == pytest.approx(6.0, abs=1e-3)
    assert depth_run["preview"].startswith("Preview")
    assert depth_run["solid_hidden_in_preview"] and depth_run["through"]["solid_visible"]
    blind, through, undone = depth_run["before"], depth_run["through"], depth_run["undone"]
    assert blind["volume"] == pytest.approx(60 * 40 * 10 - math.pi * 16 * 6, rel=1e-5)
    assert through["valid"] and through["undo_name"] == "Push/Pull"
    assert through["volume"] == pytest.approx(60 * 40 * 10 - math.pi * 16 * 10, rel=1e-5)
    assert through["faces"] == blind["faces"] - 1  # the floor went, the bottom opened
    assert undone["volume"] == pytest.approx(blind["volume"]) and undone["faces"] == blind["faces"]
