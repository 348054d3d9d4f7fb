"""The feature layer document object without the GUI (FreeCAD imported into plain Python, as in
freecadcmd): made from a mesh, holds what the layer knows, recomputes when the source changes and
only then, survives save and reopen, feeds make_solid; bad input is refused with a clear error."""
import json
import os

import numpy as np
import pytest

import shapes

needs_freecad = pytest.mark.skipif(shapes.freecad() is None, reason="FreeCAD is not installed")


@pytest.fixture()
def document():
    FreeCAD, _, _ = shapes.freecad()
    doc = FreeCAD.newDocument("IdealizeLayerTest")
    name = doc.Name
    yield FreeCAD, doc
    for open_name in list(FreeCAD.listDocuments()):
        if open_name.startswith(name):
            FreeCAD.closeDocument(open_name)


def bracket_object(doc):
    from idealize.freecad.layer_object import freecad_mesh
    V, F, _ = shapes.tessellate_with_faces(shapes.bracket_solid(), 0.05)
    source = doc.addObject("Mesh::Feature", "Bracket")
    source.Mesh = freecad_mesh(V, F)
    doc.recompute()
    return source, V, F


@needs_freecad
def test_layer_object_holds_the_layer(document, tmp_path):
    FreeCAD, doc = document
    import idealize
    source, V, F = bracket_object(doc)
    before = source.Mesh.copy()
    layer = idealize.make_feature_layer(source)
    doc.recompute()

    direct = idealize.idealize(idealize.freecad.mesh.mesh_from_freecad(source),  # single precision, as stored
                               self_intersections=True)
    assert layer.TypeId == "Mesh::FeaturePython" and layer.Label == "Bracket_Layer" and layer.Source == source
    assert list(layer.Labels) == direct.labels.tolist()
    table = json.loads(layer.FeatureTable)
    assert [f["type"] for f in table["features"]] == [f["type"] for f in direct.features]
    assert layer.Features == len(direct.features) == 11
    assert len(table["relations"]) == len(direct.relations) and table["adjacency"]
    assert table["mesh_check"] == direct.mesh_check and table["mesh_check"]["self_intersecting_pairs"] == 0
    assert layer.Mesh.CountFacets == len(F) and layer.Mesh.CountPoints == len(V)
    idealized = idealize.freecad.mesh.mesh_from_freecad(layer.Mesh).vertices
    assert np.allclose(idealized, direct.idealized_vertices, atol=1e-5)  # single precision of Mesh
    assert len(layer.VertexDeviation) == len(V)
    assert float(layer.MaxDeviation) == pytest.approx(direct.deviation["max"])
    assert len(layer.FaceColors) == len(F)
    assert "Touched" not in layer.State  # stored as computed: the recompute had nothing to do
    assert source.Mesh.Topology == before.Topology  # the source is untouched

    # The console API: make_solid takes the document object.
    solid = idealize.make_solid(layer)
    assert solid.solid and solid.faces == 11

    # Save and reopen: the same layer, no recompute.
    path = str(tmp_path / "layer.FCStd")
    name, labels, table = layer.Name, list(layer.Labels), layer.FeatureTable
    layer_deviation = list(layer.VertexDeviation)
    doc.saveAs(path)
    FreeCAD.closeDocument(doc.Name)
    reopened = FreeCAD.openDocument(path)
    again = reopened.getObject(name)
    assert again.Proxy.Type == "IdealizeFeatureLayer"
    assert list(again.Labels) == labels and again.FeatureTable == table
    assert list(again.VertexDeviation) == pytest.approx(list(layer_deviation), nan_ok=True)
    assert "Touched" not in again.State
    assert idealize.feature_layer(again).labels.tolist() == direct.labels.tolist()
    # Saved compactly: the labels as packed binary, not one XML element per triangle.
    import zipfile
    with zipfile.ZipFile(path) as saved:
        xml = saved.read("Document.xml").decode()
    assert '<Property name="LabelsData"' in xml
    assert xml.count("<I v=") < 100


@needs_freecad
def test_layer_recomputes_when_source_or_options_change(document):
    FreeCAD, doc = document
    import idealize
    source, V, F = bracket_object(doc)
    layer = idealize.make_feature_layer(source)
    doc.recompute()
    fingerprint = layer.SourceFingerprint

    moved = source.Mesh.copy()
    moved.translate(100, 0, 0)
    source.Mesh = moved
    doc.recompute()
    assert layer.SourceFingerprint != fingerprint
    assert layer.Mesh.BoundBox.XMin == pytest.approx(source.Mesh.BoundBox.XMin, abs=1e-4)

    # Without idealization the fitted surfaces stay: the layer changes with the option.
    idealized = json.loads(layer.FeatureTable)["features"]
    layer.IdealizeRelations = False
    doc.recompute()
    fitted = json.loads(layer.FeatureTable)["features"]
    assert [f["type"] for f in fitted] == [f["type"] for f in idealized]
    assert any(f["params"] != g["params"] for f, g in zip(fitted, idealized))

    # A recompute with nothing changed keeps the stored layer (no recomputation).
    stamp = layer.SourceFingerprint
    layer.touch()
    doc.recompute()
    assert layer.SourceFingerprint == stamp


@needs_freecad
def test_new_layers_take_their_options_from_the_preferences(document):
    FreeCAD, doc = document
    import idealize
    from idealize.freecad import layer_object
    params = FreeCAD.ParamGet(layer_object.PARAMETER_PATH)
    try:
        params.SetFloat("AngleTolerance", 2.5)
        params.SetInt("RadiusTolerancePercent", 2)
        params.SetBool("IdealizeRelations", False)
        source, _, _ = bracket_object(doc)
        layer = idealize.make_feature_layer(source)
        assert float(layer.AngleTolerance) == 2.5 and layer.RadiusTolerance == 2 and layer.IdealizeRelations is False
        assert layer_object.object_options(layer) == {"angle_tolerance": 2.5, "distance_tolerance": None,
                                                      "radius_tolerance": 0.02, "idealize_relations": False,
                                                      "self_intersections": True}
    finally:
        for key in ("AngleTolerance", "RadiusTolerancePercent", "IdealizeRelations"):
            params.RemFloat(key)
            params.RemInt(key)
            params.RemBool(key)


def test_preference_page_names_the_parameters_read():
    """The preferences page (.ui) writes exactly the parameters the layer reads."""
    import os
    import xml.etree.ElementTree as ElementTree
    from idealize.freecad import layer_object
    path = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "Resources", "ui",
                        "PreferencesIdealize.ui")
    widgets = ElementTree.parse(path).getroot().iter("widget")
    entries = {}
    for widget in widgets:
        props = {p.get("name"): p.find("cstring").text for p in widget.findall("property") if p.find("cstring") is not None}
        if "prefEntry" in props:
            assert props["prefPath"] == "Mod/Idealize" and layer_object.PARAMETER_PATH.endswith(props["prefPath"])
            entries[props["prefEntry"]] = widget.get("class")
    kinds = {"App::PropertyAngle": "Gui::PrefDoubleSpinBox", "App::PropertyDistance": "Gui::PrefDoubleSpinBox",
             "App::PropertyPercent": "Gui::PrefSpinBox", "App::PropertyBool": "Gui::PrefCheckBox"}
    assert entries == {key: kinds[kind] for _, kind, key, _, _ in layer_object.OPTIONS}


@needs_freecad
def test_layer_refuses_bad_input(document):
    FreeCAD, doc = document
    import idealize
    empty = doc.addObject("Mesh::Feature", "Empty")
    doc.recompute()
    with pytest.raises(idealize.MeshError, match="no triangles"):
        idealize.make_feature_layer(empty)
    box = doc.addObject("Part::Box", "Box")
    with pytest.raises(TypeError, match="mesh object"):
        idealize.make_feature_layer(box)
    with pytest.raises(TypeError, match="feature layer"):
        idealize.make_solid(box)
    with pytest.raises(ValueError, match="angle tolerance"):
        idealize.idealize(idealize.Mesh(*shapes.icosphere()), angle_tolerance=0)


def test_deviation_colors_scale_and_missing_values():
    from idealize.freecad.mesh import DEVIATION_STOPS, SURFACE_COLORS, deviation_colors
    colors = deviation_colors([0.0, 0.5, 1.0, 7.0, float("nan")], 1.0)
    assert np.allclose(colors[0], DEVIATION_STOPS[0]) and np.allclose(colors[2], DEVIATION_STOPS[-1])
    assert np.allclose(colors[3], DEVIATION_STOPS[-1])  # clamped above the scale
    assert np.allclose(colors[1], DEVIATION_STOPS[len(DEVIATION_STOPS) // 2])
    assert np.allclose(colors[4], SURFACE_COLORS["freeform"])


def test_option_defaults_have_one_source():
    """The options' defaults come from the native core: the Python API, the document object's
    options and the task panel (which shows the object's values and holds none of its own). The
    preference page, a .ui file FreeCAD loads without code, shows its own values until the user
    saves: they must be the native ones."""
    import inspect
    import os
    import xml.etree.ElementTree as ElementTree
    import idealize
    from idealize.freecad import layer_object
    from idealize._loader import native
    defaults = native.feature_defaults()
    signature = inspect.signature(idealize.idealize).parameters
    assert signature["angle_tolerance"].default == defaults["angle_tolerance_degrees"]
    assert signature["radius_tolerance"].default == defaults["radius_tolerance"]
    assert signature["idealize_relations"].default == defaults["idealize"]
    option = {name: default for name, _, _, default, _ in layer_object.OPTIONS}
    assert option == {"AngleTolerance": defaults["angle_tolerance_degrees"], "DistanceTolerance": defaults["distance_tolerance"],
                      "RadiusTolerance": round(100 * defaults["radius_tolerance"]), "IdealizeRelations": defaults["idealize"]}
    ui = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "Resources", "ui")
    panel = ElementTree.parse(os.path.join(ui, "FeatureLayer.ui"))
    assert not [p for p in panel.iter("property") if p.get("name") == "value"]
    shown = {}
    for widget in ElementTree.parse(os.path.join(ui, "PreferencesIdealize.ui")).iter("widget"):
        entry = widget.find("property[@name='prefEntry']/cstring")
        if entry is None:
            continue
        value = widget.find("property[@name='value']/double")
        if value is None:
            value = widget.find("property[@name='value']/number")
        checked = widget.find("property[@name='checked']/bool")
        shown[entry.text] = (float(value.text) if value is not None else
                             (checked.text == "true") if checked is not None else None)
    assert shown["AngleTolerance"] == defaults["angle_tolerance_degrees"]
    assert shown["RadiusTolerancePercent"] == round(100 * defaults["radius_tolerance"])
    assert shown["IdealizeRelations"] == defaults["idealize"]
    assert shown.get("DistanceTolerance") in (None, defaults["distance_tolerance"])


def test_the_core_api_imports_nothing_of_freecad():
    """`import idealize` and a conversion load no FreeCAD module: the FreeCAD glue lives in
    idealize.freecad, the GUI in idealize.gui. Documents saved by earlier versions name the layer's
    proxy as idealize.layer_object.FeatureLayerObject, which still resolves."""
    import subprocess
    import sys
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    code = ("import sys; import idealize; import numpy as np; "
            "V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float); "
            "F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.int32); "
            "idealize.make_solid(idealize.idealize(idealize.Mesh(V, F))); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('FreeCAD', 'Part', 'Mesh', 'FreeCADGui', 'PySide')"
            " or m.startswith(('idealize.freecad', 'idealize.gui'))))")
    out = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout
    old = subprocess.run([sys.executable, "-c", "import sys; sys.path.append('/usr/lib/freecad-python3/lib'); import FreeCAD; "
                          "from idealize.layer_object import FeatureLayerObject as A; "
                          "from idealize.freecad.layer_object import FeatureLayerObject as B; print(A is B)"],
                         cwd=root, capture_output=True, text=True)
    assert old.stdout.strip() == "True", old.stderr


@needs_freecad
def test_edits_are_kept_replayed_on_recompute_and_saved(document, tmp_path):
    """add_edit stores the edited layer and the edit; a recompute after an option change idealizes
    the source again and replays it; save and reopen keep it; the source is untouched."""
    FreeCAD, doc = document
    import idealize
    from idealize.freecad import layer_object
    source, V, F = bracket_object(doc)
    before = source.Mesh.copy()
    layer = idealize.make_feature_layer(source)
    table = json.loads(layer.FeatureTable)
    top = [f["id"] for f in table["features"] if f["type"] == "plane" and f["params"]["normal"][2] > 0.99
           and abs(f["params"]["point"][2] - 20) < 1e-6][0]
    edited = layer_object.add_edit(layer, {"op": "push_pull", "feature_id": top, "distance": 4.0})
    doc.recompute()
    assert "Touched" not in layer.State  # stored as computed
    assert len(json.loads(layer.Edits)) == 1 and layer.Mesh.CountFacets == len(edited.mesh.faces)
    stored = idealize.feature_layer(layer)
    assert stored.features[top]["params"]["point"][2] == pytest.approx(24.0)
    volume = idealize.make_solid(stored).volume
    assert volume == pytest.approx(idealize.make_solid(edited).volume, rel=1e-6)
    # An option change recomputes from the source, and replays the edit.
    layer.RadiusTolerance = layer.RadiusTolerance + 1
    doc.recompute()
    replayed = idealize.feature_layer(layer)
    assert replayed.features[top]["params"]["point"][2] == pytest.approx(24.0)
    assert idealize.make_solid(replayed).volume == pytest.approx(volume, rel=1e-4)
    path = str(tmp_path / "edited.FCStd")
    doc.saveAs(path)
    name = layer.Name
    FreeCAD.closeDocument(doc.Name)
    reopened = FreeCAD.openDocument(path)
    again = idealize.feature_layer(reopened.getObject(name))
    assert again.features[top]["params"]["point"][2] == pytest.approx(24.0)
    assert reopened.getObject("Bracket").Mesh.Topology == before.Topology


@needs_freecad
def test_an_edit_prepared_in_another_thread_stores_what_add_edit_would(document):
    """edit_inputs (read in the GUI thread) and edit_record (a worker's): storing the record gives
    the object what add_edit computing it there gives, edits and all."""
    FreeCAD, doc = document
    import threading
    import idealize
    from idealize.freecad import layer_object
    source, V, F = bracket_object(doc)
    first, second = idealize.make_feature_layer(source), idealize.make_feature_layer(source)
    top = [f["id"] for f in json.loads(first.FeatureTable)["features"] if f["type"] == "plane"
           and f["params"]["normal"][2] > 0.99 and abs(f["params"]["point"][2] - 20) < 1e-6][0]
    step = {"op": "push_pull", "feature_id": top, "distance": 4.0}
    inputs = layer_object.edit_inputs(first)
    made = {}
    worker = threading.Thread(target=lambda: made.update(record=layer_object.edit_record(inputs, step)))
    worker.start()
    worker.join()
    stored = layer_object.add_edit(first, step, made["record"])
    computed = layer_object.add_edit(second, step)
    doc.recompute()
    assert "Touched" not in first.State
    assert first.Edits == second.Edits and json.loads(first.Edits) == [step]
    assert first.FeatureTable == second.FeatureTable and first.Labels == second.Labels
    assert first.Mesh.Topology == second.Mesh.Topology
    assert np.array_equal(stored.idealized_vertices, computed.idealized_vertices)
