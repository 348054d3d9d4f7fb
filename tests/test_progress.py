"""Progress reporting and cancellation of the long native calls (for the GUI's worker thread)."""
import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import idealize
from data_builders import cube_mesh
from idealize import Mesh

# The step names in the order one idealize() + make_solid() run reports them.
SEGMENT_STAGES = ["prepare", "check", "refine", "denoise", "curvature", "histograms", "thinning", "map_back"]
FEATURE_STAGES = ["fit", "reassign", "split", "reassign", "merge", "reassign", "classify", "remerge", "relations",
                  "projection"]
BREP_STAGES = ["topology", "vertices", "edges", "faces", "sewing", "checking", "triangulation", "deviation",
               "done"]


def subdivided_cube(levels, noise=0.0, seed=0):
    """The unit cube with every triangle split into 4**levels, vertices moved by Gaussian noise."""
    V, F = cube_mesh()
    for _ in range(levels):
        edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        unique, index = np.unique(edges, axis=0, return_inverse=True)
        index = index.reshape(3, -1) + len(V)
        V = np.vstack([V, 0.5 * (V[unique[:, 0]] + V[unique[:, 1]])])
        a, b, c = F.T
        ab, bc, ca = index
        F = np.concatenate([np.stack(t, axis=1) for t in ([a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca])])
    if noise:
        V = V + np.random.default_rng(seed).normal(0.0, noise, V.shape)
    return Mesh(np.ascontiguousarray(V), np.ascontiguousarray(F, dtype=np.int32))


@pytest.fixture(scope="module")
def small_scan():
    return subdivided_cube(5, noise=2e-4)  # 12k triangles


@pytest.fixture(scope="module")
def large_scan():
    return subdivided_cube(7, noise=2e-4)  # 200k triangles: segment() takes over a second


@pytest.fixture(scope="module")
def huge_scan():
    # 790k triangles: idealize() takes about 8 s, so a run that did not poll would go on for
    # seconds after any of the moments the test cancels at.
    return subdivided_cube(8, noise=2e-4)


class Sampler:
    """Reads (fraction, stage) from another thread every millisecond while a call runs."""

    def __init__(self, progress):
        self.progress = progress
        self.samples = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        while not self._stop.is_set():
            self.samples.append((self.progress.fraction, self.progress.stage))
            time.sleep(0.001)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        self.samples.append((self.progress.fraction, self.progress.stage))

    def stages(self):
        seen = []
        for _, stage in self.samples:
            if stage and (not seen or seen[-1] != stage):
                seen.append(stage)
        return seen


def in_order(seen, order):
    """The stages were seen in the given order (some may be missed between two samples)."""
    remaining = iter(order)
    return all(any(stage == expected for expected in remaining) for stage in seen)


def run_in_thread(function):
    """Starts function() in a thread; returns (thread, outcome) with outcome filled on return."""
    outcome = {}

    def target():
        try:
            outcome["result"] = function()
        except BaseException as error:  # noqa: B902 (recorded for the test thread)
            outcome["error"] = error
        outcome["end"] = time.perf_counter()

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    return thread, outcome


def test_progress_object_basics():
    progress = idealize.Progress()
    assert progress.fraction == 0.0 and progress.stage == "" and not progress.cancelled
    assert progress.range == (0.0, 1.0)
    progress.set_range(0.25, 0.75)
    progress.report("step", 0.5)
    assert progress.fraction == pytest.approx(0.5) and progress.stage == "step"
    progress.report("step", 0.2)  # never backwards
    assert progress.fraction == pytest.approx(0.5)
    progress.cancel()
    assert progress.cancelled
    assert issubclass(idealize.Cancelled, RuntimeError)


def test_same_result_and_increasing_progress(small_scan):
    plain = idealize.idealize(small_scan)
    progress = idealize.Progress()
    with Sampler(progress) as sampler:
        watched = idealize.idealize(small_scan, progress=progress)
    np.testing.assert_array_equal(watched.labels, plain.labels)
    np.testing.assert_array_equal(watched.segmentation.labels, plain.segmentation.labels)
    assert [(f["type"], f["params"], f["rms"]) for f in watched.features] == \
        [(f["type"], f["params"], f["rms"]) for f in plain.features]
    np.testing.assert_array_equal(watched.idealized_vertices, plain.idealized_vertices)

    assert progress.fraction == 1.0
    assert progress.range == (0.0, 1.0)  # idealize split the range and gave it back
    fractions = [f for f, _ in sampler.samples]
    assert fractions == sorted(fractions)
    seen = sampler.stages()
    assert in_order(seen, SEGMENT_STAGES + FEATURE_STAGES), seen
    assert seen[-1] == "projection"
    assert len(seen) >= 3, seen


def test_segment_fills_the_range_it_is_given(small_scan):
    progress = idealize.Progress()
    progress.set_range(0.2, 0.5)
    idealize.segment(small_scan, progress=progress)
    assert progress.fraction == pytest.approx(0.5)
    assert progress.stage == "map_back"


def test_cancel_during_idealize_stops_promptly(huge_scan):
    for moment in (0.05, 0.2, 0.35):  # refinement, denoising (a cube's identification takes no time)
        progress = idealize.Progress()
        start = time.perf_counter()
        thread, outcome = run_in_thread(lambda: idealize.idealize(huge_scan, progress=progress))
        while progress.fraction < moment and thread.is_alive():
            time.sleep(0.002)
        assert thread.is_alive(), "the mesh is too small to cancel the run at %.2f" % moment
        cancelled_at = time.perf_counter()
        progress.cancel()
        thread.join(30)
        assert isinstance(outcome.get("error"), idealize.Cancelled), outcome
        assert "result" not in outcome
        latency = outcome["end"] - cancelled_at
        # Measured well under 0.1 s; a run without polling would go on for 3 s or more.
        assert latency < 2.0, "cancelled at %.2f after %.2f s: took %.2f s" % (
            moment, cancelled_at - start, latency)


def test_gil_is_released(large_scan):
    count = [0]
    stop = threading.Event()

    def counter():
        while not stop.is_set():
            count[0] += 1

    thread = threading.Thread(target=counter, daemon=True)
    thread.start()
    try:
        time.sleep(0.05)
        before = count[0]
        time.sleep(0.2)  # the counter's speed while this thread waits without the GIL
        rate = (count[0] - before) / 0.2
        before = count[0]
        start = time.perf_counter()
        idealize._native.segment(large_scan.vertices, large_scan.faces)
        elapsed = time.perf_counter() - start
        during = count[0] - before
    finally:
        stop.set()
        thread.join()
    assert elapsed > 0.5
    # Holding the GIL, the counter would get only a few switch intervals of the short Python
    # parts (milliseconds); without it, most of the run even on a busy machine.
    assert during > 0.3 * rate * elapsed, (during, rate, elapsed)


def test_cancelled_progress_stops_at_once(small_scan):
    progress = idealize.Progress()
    progress.cancel()
    layer = idealize.idealize(small_scan)
    calls = [
        lambda: idealize.segment(small_scan, progress=progress),
        lambda: idealize.idealize(small_scan, progress=progress),
        lambda: idealize.idealize(small_scan, segmentation=layer.segmentation, progress=progress),
        lambda: idealize.make_solid(layer, progress=progress),
        lambda: idealize._native.mesh_distances(small_scan.vertices, small_scan.faces, small_scan.vertices,
                                                progress=progress),
    ]
    for call in calls:
        start = time.perf_counter()
        with pytest.raises(idealize.Cancelled):
            call()
        assert time.perf_counter() - start < 0.5


def test_make_solid_reports_and_cancels():
    mesh = subdivided_cube(4)
    layer = idealize.idealize(mesh)
    plain = idealize.make_solid(layer)
    assert plain.solid
    progress = idealize.Progress()
    with Sampler(progress) as sampler:
        watched = idealize.make_solid(layer, progress=progress)
    assert (watched.solid, watched.faces, watched.surface_types, watched.max_deviation) == \
        (plain.solid, plain.faces, plain.surface_types, plain.max_deviation)
    assert watched.volume == plain.volume
    assert watched.brep_string() == plain.brep_string()
    assert progress.fraction == 1.0
    fractions = [f for f, _ in sampler.samples]
    assert fractions == sorted(fractions)
    seen = sampler.stages()
    assert in_order(seen, BREP_STAGES), seen
    assert seen[-1] == "done"

    # A cancel while it runs (from the progress callback's point of view: at its first report).
    progress = idealize.Progress()
    thread, outcome = run_in_thread(lambda: idealize.make_solid(layer, progress=progress))
    progress.cancel()
    thread.join(30)
    assert isinstance(outcome.get("error"), idealize.Cancelled) or "result" in outcome


QT_SLOT_CHECK = """
import sys
sys.path.insert(0, %r)
from PySide2 import QtWidgets
import idealize
app = QtWidgets.QApplication([])
dialog = QtWidgets.QProgressDialog("idealize", "Cancel", 0, 100)
for progress in (idealize.Progress(), idealize._native.Progress()):
    dialog.canceled.connect(progress.cancel)
dialog.canceled.emit()
print("cancelled" if progress.cancelled else "not cancelled")
"""


def test_cancel_is_a_qt_slot():
    # What the GUI does: Cancel button -> progress.cancel. PySide2 5.15 crashes when a signal is
    # connected to a method of a compiled class, so Progress.cancel is a Python function.
    pytest.importorskip("PySide2")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen")
    proc = subprocess.run([sys.executable, "-c", QT_SLOT_CHECK % root], env=env, capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == "cancelled"
