"""The command line contract: python -m idealize convert INPUT -o OUT.step --report REPORT.json"""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import shapes
from data_builders import write_binary_stl

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "idealize", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=300)


@pytest.fixture
def sphere_stl(tmp_path):
    V, F = shapes.icosphere(radius=10.0, subdivisions=3)
    path = tmp_path / "sphere.stl"
    write_binary_stl(path, V, F)
    return path, len(F)


def test_convert_writes_report_with_public_keys(tmp_path, sphere_stl):
    path, triangles = sphere_stl
    report_path = tmp_path / "report.json"
    result = run_cli("convert", str(path), "-o", str(tmp_path / "out.step"), "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    assert report["input"]["triangles"] == triangles
    assert report["input"]["vertices"] == 642  # welded
    assert len(report["labels"]) == triangles and all(isinstance(x, int) for x in report["labels"])
    assert report["features"] and {"id", "triangles", "type", "params", "rms"} <= set(report["features"][0])
    assert {"adjacency", "relations", "deviation"} <= set(report)
    assert sum(f["triangles"] for f in report["features"]) == sum(1 for x in report["labels"] if x >= 0)
    assert all(0 <= t < triangles for t in report["transition_triangles"])
    assert report["timings"]["total"] > 0 and "segment" in report["timings"]
    # The fitted solid: one sphere face, its volume, and the STEP file holding it.
    brep = report["brep"]
    assert {"valid", "closed", "solid", "faces", "volume", "surface_types", "max_deviation", "max_tolerance"} <= set(brep)
    assert brep["solid"] and brep["valid"] and brep["closed"] and brep["faces"] == 1
    assert brep["surface_types"] == {"sphere": 1}
    assert brep["volume"] == pytest.approx(4 / 3 * np.pi * 1000, rel=2e-3)  # icosphere radius 10
    assert brep["max_deviation"] < 0.2
    assert report["step"] == {"written": True, "path": str(tmp_path / "out.step"), "solid": True}
    assert (tmp_path / "out.step").read_text().startswith("ISO-10303-21;")
    assert "brep" in report["timings"] and "step" in report["timings"]


def test_convert_without_a_solid_writes_faces_and_exits_1(tmp_path):
    """An open mesh (a box without its top) cannot close: its five faces are written, the report
    says why, and the exit status is 1."""
    V = np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0],
                  [0, 0, 10], [10, 0, 10], [10, 10, 10], [0, 10, 10]], float)
    quads = [(0, 3, 2, 1), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    F = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))], np.int32)
    path = tmp_path / "open.stl"
    write_binary_stl(path, V, F)
    report_path = tmp_path / "r.json"
    result = run_cli("convert", str(path), "-o", str(tmp_path / "o.step"), "--report", str(report_path))
    assert result.returncode == 1, result.stderr
    assert "no valid closed solid" in result.stderr
    report = json.loads(report_path.read_text())
    assert report["brep"]["solid"] is False and report["brep"]["closed"] is False
    assert report["brep"]["faces"] == 5 and report["brep"]["problems"]
    assert report["step"]["written"] is True and report["step"]["solid"] is False


def test_labels_follow_input_file_order(tmp_path, sphere_stl):
    path, _ = sphere_stl
    report_path = tmp_path / "report.json"
    assert run_cli("convert", str(path), "-o", str(tmp_path / "o.step"), "--report", str(report_path)).returncode == 0
    import idealize
    expected = idealize.idealize(idealize.load_mesh(path)).labels
    assert json.loads(report_path.read_text())["labels"] == expected.tolist()


def test_sphere_report_has_type_and_parameters(tmp_path, sphere_stl):
    path, _ = sphere_stl
    report_path = tmp_path / "report.json"
    assert run_cli("convert", str(path), "-o", str(tmp_path / "o.step"), "--report", str(report_path)).returncode == 0
    report = json.loads(report_path.read_text())
    (sphere,) = report["features"]
    assert sphere["type"] == "sphere"
    # The icosphere's vertices lie on r = 10; its flat facets pull a least-squares fit slightly in.
    assert abs(sphere["params"]["radius"] - 10.0) < 0.05
    assert np.linalg.norm(sphere["params"]["center"]) < 1e-6
    assert sphere["rms"] < 0.05 and report["deviation"]["max"] < 0.05


@pytest.mark.skipif(shapes.freecad() is None, reason="FreeCAD is not installed")
def test_bracket_report_features_graph_and_relations(tmp_path):
    V, F, _ = shapes.tessellate_with_faces(shapes.bracket_solid(), 0.05)
    path = tmp_path / "bracket.stl"
    write_binary_stl(path, V, F)
    report_path = tmp_path / "report.json"
    assert run_cli("convert", str(path), "-o", str(tmp_path / "o.step"), "--report", str(report_path)).returncode == 0
    report = json.loads(report_path.read_text())
    features = report["features"]
    assert sorted(f["type"] for f in features) == ["cylinder"] * 5 + ["plane"] * 6
    param_keys = {"plane": {"normal", "point"}, "cylinder": {"axis", "point", "radius"}}
    assert all(set(f["params"]) == param_keys[f["type"]] and "rms" in f for f in features)
    radii = sorted(round(f["params"]["radius"], 2) for f in features if f["type"] == "cylinder")
    assert radii == [5.0, 5.0, 5.0, 5.0, 8.0]  # float STL: within 0.005
    fillets = sorted(f["id"] for f in features if f["type"] == "cylinder" and f["params"]["radius"] < 6)
    assert {"kind": "equal_radius", "features": fillets} in report["relations"]
    # Fillets meet the side planes tangentially, the top and bottom sharply (the count of tangent
    # pairs is checked in test_features on the double-precision mesh).
    kind = {f["id"]: f["type"] for f in features}
    for edge in report["adjacency"]:
        pair = {kind[edge["a"]], kind[edge["b"]]}
        if edge["continuity"] == "G1":
            assert pair == {"plane", "cylinder"}
    assert sum(e["continuity"] == "G1" for e in report["adjacency"]) >= 4
    assert report["deviation"]["max"] < 1e-3 and report["deviation"]["rms"] <= report["deviation"]["max"]
    # Exact fits: radii fixed to far below the tolerance, a form that does not depart from them.
    assert all(0.0 <= f["radius_error"] < 1e-3 for f in features if f["type"] == "cylinder")
    assert all("radius_error" not in f for f in features if f["type"] == "plane")
    assert 0.0 <= report["form_deviation"] < 1e-4


def test_bad_input_exits_with_message(tmp_path):
    bad = tmp_path / "empty.stl"
    bad.write_bytes(b"")
    result = run_cli("convert", str(bad), "-o", str(tmp_path / "o.step"), "--report", str(tmp_path / "r.json"))
    assert result.returncode == 2
    assert "error:" in result.stderr and "empty" in result.stderr
    assert "Traceback" not in result.stderr
    assert not (tmp_path / "r.json").exists()


def test_missing_file(tmp_path):
    result = run_cli("convert", str(tmp_path / "nope.stl"), "-o", str(tmp_path / "o.step"))
    assert result.returncode == 2 and "No such file" in result.stderr


def test_same_input_gives_identical_output(tmp_path):
    """Byte-identical labels and report (timings aside) and STEP (its header's time stamp aside),
    from separate processes on one thread and on two (IDEALIZE_THREADS) with different hashing:
    the items the two threads share out write only what is their own, and nothing depends on
    addresses or hash order."""
    V, F, _ = shapes.tessellate_with_faces(shapes.bracket_solid(), 0.05)
    rng = np.random.default_rng(7)
    V = V + rng.normal(scale=0.02, size=V.shape)  # a scan: the hard case for exact repeats
    path = tmp_path / "bracket.stl"
    write_binary_stl(path, V, F)
    outputs = []
    for run, threads in enumerate(("1", "2")):
        env = dict(os.environ, IDEALIZE_THREADS=threads, PYTHONHASHSEED=str(run + 11))
        out, report = tmp_path / ("out%d.step" % run), tmp_path / ("report%d.json" % run)
        result = subprocess.run([sys.executable, "-m", "idealize", "convert", str(path), "-o", str(out), "--report",
                                 str(report)], cwd=ROOT, capture_output=True, text=True, timeout=300, env=env)
        assert result.returncode in (0, 1), result.stderr
        data = json.loads(report.read_text())
        data.pop("timings")
        data["step"].pop("path")
        step = [line for line in out.read_text().splitlines() if not line.startswith("FILE_NAME")]
        outputs.append((json.dumps(data, sort_keys=True), step))
    assert outputs[0][0] == outputs[1][0]
    assert outputs[0][1] == outputs[1][1]
