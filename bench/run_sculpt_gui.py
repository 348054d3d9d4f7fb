"""Sculpt mode's interactivity in the real FreeCAD GUI (under Xvfb) on a mesh of about 100k triangles
(issue 53: "the view stays interactive on a 100k-triangle mesh").

A 100 x 60 x 20 block meshed by Mefisto at 0.55 mm (108k triangles) is idealized through the
workbench; Sculpt mode then gets STROKES drags of synthetic mouse events across the top face (draw,
a radius covering about 5k triangles per four radii of stroke). A 5 ms timer records each turn of
the GUI's event loop. Measured per stroke:
- the press (the panel's Sculptor made from the layer when it has changed, the first dab, the
  preview drawn in place of the layer);
- each mouse move's handling during a drag of about 50 moves a second (the pick under the pointer,
  the brush circle, the dabs up to it), how often and how fast the clay's preview is drawn, and the
  event loop's longest pause during the drag;
- from the release until the stroke is stored: the longest pause of the event loop (the worker
  thread sculpts and re-idealizes; the GUI thread stores the result as one undo step, draws the
  layer and regenerates nothing, as no solid was made), and the whole time.

Usage: /usr/bin/python3 bench/run_sculpt_gui.py  (bench/results/sculpt-gui.json; about a minute).
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gui_driver  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
STROKES = 3
MAX_LENGTH = 0.55  # Mefisto's MaxLength on the block: 108k triangles, as bench/run_sculpt.py's speed part
STROKE_TRIANGLES = 5000
MOVE_INTERVAL = 0.02  # seconds between a drag's mouse moves: about 50 a second, as a hand makes them

DRIVER = r'''
import sys, time
import numpy as np

sys.path.insert(0, CONFIG["repo"])


def run():
    from PySide import QtCore, QtGui
    import MeshPart, Part
    Gui.activateWorkbench("IdealizeWorkbench")
    QtGui.QMessageBox.critical = lambda parent, title, text, *rest: result.setdefault("errors", []).append(text)
    doc = App.newDocument("SculptSpeed")
    source = doc.addObject("Mesh::Feature", "Block")
    source.Mesh = MeshPart.meshFromShape(Shape=Part.makeBox(100, 60, 20), MaxLength=CONFIG["max_length"])
    doc.recompute()
    Gui.Selection.clearSelection()
    Gui.Selection.addSelection(source)
    names = {o.Name for o in doc.Objects}
    Gui.runCommand("Idealize_SegmentIdealize")
    Gui.updateGui()
    layer = [o for o in doc.Objects if o.Name not in names][0]
    view = Gui.ActiveDocument.ActiveView
    view.viewTop()
    view.fitAll()
    Gui.updateGui()
    Gui.Selection.clearSelection()
    Gui.Selection.addSelection(doc.Name, layer.Name)
    Gui.runCommand("Idealize_Sculpt")
    Gui.updateGui()
    from idealize.gui import task_sculpt
    panel = task_sculpt.active_panel
    triangles = layer.Mesh.CountFacets
    area = 100 * 60 * 2 + 2 * (100 + 60) * 20
    radius = float(np.sqrt(CONFIG["stroke_triangles"] * area / triangles / (8.0 + np.pi)))
    form = panel.form
    form.brush.setCurrentIndex(form.brush.findData("draw"))
    form.radius.setValue(radius)
    form.strength.setValue(0.5)
    screen, send = mouse_events(view)

    ticks = []
    timer = QtCore.QTimer()
    timer.timeout.connect(lambda: ticks.append(time.perf_counter()))
    timer.start(5)
    strokes = []
    refreshes = []  # the preview of the clay drawn: how long each took
    original_refresh = panel.refresh

    def timed_refresh():
        start = time.perf_counter()
        original_refresh()
        refreshes.append(time.perf_counter() - start)
    panel.refresh = timed_refresh  # before the panel's refresh timer is made, which calls it too
    for k in range(CONFIG["strokes"]):
        y = 15.0 + 30.0 * k / max(1, CONFIG["strokes"] - 1)
        path = [screen((20 + 4 * radius * t / 10, y, 20)) for t in range(11)]
        moves = []
        send(QtCore.QEvent.MouseMove, path[0], QtCore.Qt.NoButton)
        start = time.perf_counter()
        send(QtCore.QEvent.MouseButtonPress, path[0], QtCore.Qt.LeftButton)
        press = time.perf_counter() - start
        drawn, first_tick = len(refreshes), len(ticks)
        drag_start = time.perf_counter()
        for point in path[1:]:
            start = time.perf_counter()
            send(QtCore.QEvent.MouseMove, point, QtCore.Qt.LeftButton)
            moves.append(time.perf_counter() - start)
            # A hand moves the mouse at about 50 events a second: the event loop runs meanwhile.
            while time.perf_counter() - start < CONFIG["move_interval"]:
                QtGui.QApplication.processEvents()
                time.sleep(0.001)
        drag_gaps = np.diff([drag_start] + [t for t in ticks[first_tick:]] + [time.perf_counter()])
        drag = {"press_ms": 1000 * press, "drawn_during_drag": len(refreshes) - drawn,
                "drag_longest_pause_ms": 1000 * float(drag_gaps.max())}
        released = time.perf_counter()
        send(QtCore.QEvent.MouseButtonRelease, path[-1], QtCore.Qt.NoButton)
        first = len(ticks)
        while panel.busy and time.perf_counter() - released < 60:
            QtGui.QApplication.processEvents()
            time.sleep(0.001)
        stored = time.perf_counter()
        QtGui.QApplication.processEvents()
        after = [released] + [t for t in ticks[first:] if t <= stored] + [stored]
        gaps = np.diff(after)
        strokes.append(dict(drag, moves_ms=[1000 * m for m in moves], stored_s=stored - released,
                            longest_pause_ms=1000 * float(gaps.max()), undo_steps=len(doc.UndoNames)))
    timer.stop()
    result.update(triangles=triangles, radius=radius, strokes=strokes, status=form.status.text(),
                  triangles_after=layer.Mesh.CountFacets, refresh_ms=[1000 * r for r in refreshes])
    panel.close()
'''


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="sculpt-gui", help="results/NAME.json")
    args = parser.parse_args(argv)
    config = {"repo": str(Path(__file__).resolve().parents[1]), "max_length": MAX_LENGTH, "strokes": STROKES,
              "stroke_triangles": STROKE_TRIANGLES, "move_interval": MOVE_INTERVAL}
    with tempfile.TemporaryDirectory() as tmp:
        config["result"] = str(Path(tmp) / "result.json")
        result = gui_driver.run_in_freecad_gui(gui_driver.MOUSE + DRIVER, config, Path(tmp) / "driver.py", timeout=900)
    if "exception" in result:
        raise SystemExit(result["exception"])
    moves = [m for s in result["strokes"] for m in s["moves_ms"]]
    live = result.get("refresh_ms") or [float("nan")]
    summary = {"triangles": result["triangles"], "radius": result["radius"],
               "move_ms_median": statistics.median(moves), "move_ms_max": max(moves),
               "press_ms_max": max(s.get("press_ms", 0.0) for s in result["strokes"]),
               "drawn_during_drag": [s.get("drawn_during_drag", 0) for s in result["strokes"]],
               "drag_longest_pause_ms": max(s.get("drag_longest_pause_ms", 0.0) for s in result["strokes"]),
               "preview_ms_median": statistics.median(live),
               "longest_pause_ms": max(s["longest_pause_ms"] for s in result["strokes"]),
               "stored_s": [s["stored_s"] for s in result["strokes"]], "raw": result}
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / ("%s.json" % args.out)).write_text(json.dumps(summary, indent=1))
    print("Sculpt mode on %d triangles (brush radius %.2f): the press %.0f ms at most; mouse moves during a drag "
          "(50 a second) %.0f ms median, %.0f ms at most; the clay's preview drawn %s times per drag, %.0f ms "
          "median, the event loop's longest pause during a drag %.0f ms; from the release to the stored stroke "
          "%s s, the event loop's longest pause %.0f ms."
          % (summary["triangles"], summary["radius"], summary["press_ms_max"], summary["move_ms_median"],
             summary["move_ms_max"], "/".join(str(n) for n in summary["drawn_during_drag"]),
             summary["preview_ms_median"], summary["drag_longest_pause_ms"],
             ", ".join("%.2f" % s for s in summary["stored_s"]), summary["longest_pause_ms"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
