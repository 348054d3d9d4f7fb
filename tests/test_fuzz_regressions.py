"""Inputs found by the fuzz targets (native/fuzz/) must never crash Idealize.

Every file in native/fuzz/regressions/ is read in a child process, so that a segmentation fault or
an abort fails the test instead of killing pytest. Mesh files (.stl, .obj, .off, .ply) go through
idealize.load_mesh; .seg files hold the byte layout of the fuzz_segment target (decoded below as the
target does) and go through idealize.idealize. Either may succeed or raise idealize.MeshError;
anything else fails. The seed corpora of the fuzz targets are checked the same way and must load.
"""
import glob
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FUZZ = os.path.join(ROOT, "native", "fuzz")
MESH_EXTENSIONS = (".stl", ".obj", ".off", ".ply")

CHILD = r"""
import struct, sys
import numpy as np
sys.path.insert(0, sys.argv[1])
import idealize

def decode_segment_input(data):
    # The layout of native/fuzz/fuzz_segment.cpp; missing bytes read as zero.
    data = data + bytes(3 + 66 * 6 + 128 * 3)
    nv = 3 + data[0] % 64
    nf = 1 + data[1] % 128
    scale = 2.0 ** -(data[2] % 16)
    coords = struct.unpack_from("<%dh" % (3 * nv), data, 3)
    vertices = np.array(coords, dtype=np.float64).reshape(nv, 3) * scale
    start = 3 + 6 * nv
    faces = np.array([b % nv for b in data[start:start + 3 * nf]], dtype=np.int32).reshape(nf, 3)
    return idealize.Mesh(vertices, faces)

path = sys.argv[2]
try:
    if path.endswith(".seg"):
        with open(path, "rb") as stream:
            mesh = decode_segment_input(stream.read())
        layer = idealize.idealize(mesh)
        assert len(layer.labels) == len(mesh.faces)
        print("refined", len(layer.segmentation.working["working_faces"]))
    else:
        mesh = idealize.load_mesh(path)
        assert len(mesh.faces) > 0
        assert np.isfinite(mesh.vertices).all()
        assert mesh.faces.min() >= 0 and mesh.faces.max() < len(mesh.vertices)
    print("ok")
except idealize.MeshError as error:
    print("MeshError:", error)
"""


def run_child(path):
    return subprocess.run([sys.executable, "-c", CHILD, ROOT, path], capture_output=True, text=True,
                          timeout=300)


def regression_inputs():
    return sorted(glob.glob(os.path.join(FUZZ, "regressions", "*")))


def seed_inputs():
    # fuzz_sculpt's and fuzz_edit's seeds are byte layouts of strokes on a generated sphere and of
    # edits of generated parts, not meshes: tools/fuzz.sh (and so tools/test.sh) runs every one of
    # them first, the inputs that once crashed among them.
    return sorted(p for p in glob.glob(os.path.join(FUZZ, "corpus", "*", "*"))
                  if os.path.basename(os.path.dirname(p)) not in ("fuzz_sculpt", "fuzz_edit"))


def check_no_crash(path):
    result = run_child(path)
    assert result.returncode == 0, "%s: exit status %d\n%s%s" % (
        os.path.relpath(path, ROOT), result.returncode, result.stdout, result.stderr[-4000:])
    return result.stdout


@pytest.mark.parametrize("path", [p for p in regression_inputs()
                                  if p.endswith(MESH_EXTENSIONS + (".seg",))],
                         ids=lambda p: os.path.basename(str(p)))
def test_fuzz_regression_does_not_crash(path):
    check_no_crash(path)


@pytest.mark.parametrize("path", seed_inputs(), ids=lambda p: "/".join(str(p).split(os.sep)[-2:]))
def test_fuzz_seed_is_valid(path):
    assert check_no_crash(path).split()[-1] == "ok"


KNOWN_SLOW = sorted(glob.glob(os.path.join(FUZZ, "known-slow", "*.seg")))


@pytest.mark.parametrize("path", KNOWN_SLOW, ids=lambda p: os.path.basename(str(p)))
def test_fuzz_slow_input_is_refined_within_bounds(path):
    # Slivers that no split mends once took refinement to 1.6 million faces (65 s); it now stops at
    # 12 times an even sampling of 20000 triangles (RefinementOptions::max_oversampling).
    output = check_no_crash(path)
    refined = int(output.split("refined")[1].split()[0])
    assert refined <= 12 * 20000 + 128, output
