"""Sculpt mode's interactivity in the real FreeCAD GUI (under Xvfb) on a mesh of about 100k triangles
(issue 53: "the view stays interactive on a 100k-triangle mesh").

A 100 x 60 x 20 block meshed by Mefisto at 0.55 mm (108k triangles) is idealized through the
workbench; Sculpt mode then gets STROKES drags of synthetic mouse events across the top face (draw,
a radius covering about 5k triangles per four radii of stroke). A 5 ms timer records each turn of
the GUI's event loop. Measured per stroke:
- each mouse move's handling during the drag (the pick under the pointer and the brush circle);
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
    for k in range(CONFIG["strokes"]):
        y = 15.0 + 30.0 * k / max(1, CONFIG["strokes"] - 1)
        path = [screen((20 + 4 * radius * t / 10, y, 20)) for t in range(11)]
        moves = []
        send(QtCore.QEvent.MouseMove, path[0], QtCore.Qt.NoButton)
        send(QtCore.QEvent.MouseButtonPress, path[0], QtCore.Qt.LeftButton)
        for point in path[1:]:
            start = time.perf_counter()
            send(QtCore.QEvent.MouseMove, point, QtCore.Qt.LeftButton)
            moves.append(time.perf_counter() - start)
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
        strokes.append({"moves_ms": [1000 * m for m in moves], "stored_s": stored - released,
                        "longest_pause_ms": 1000 * float(gaps.max()), "undo_steps": len(doc.UndoNames)})
    timer.stop()
    result.update(triangles=triangles, radius=radius, strokes=strokes, status=form.status.text(),
                  triangles_after=layer.Mesh.CountFacets)
    panel.close()
'''


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="sculpt-gui", help="results/NAME.json")
    args = parser.parse_args(argv)
    config = {"repo": str(Path(__file__).resolve().parents[1]), "max_length": MAX_LENGTH, "strokes": STROKES,
              "stroke_triangles": STROKE_TRIANGLES}
    with tempfile.TemporaryDirectory() as tmp:
        config["result"] = str(Path(tmp) / "result.json")
        result = gui_driver.run_in_freecad_gui(gui_driver.MOUSE + DRIVER, config, Path(tmp) / "driver.py", timeout=900)
    if "exception" in result:
        raise SystemExit(result["exception"])
    moves = [m for s in result["strokes"] for m in s["moves_ms"]]
    summary = {"triangles": result["triangles"], "radius": result["radius"],
               "move_ms_median": statistics.median(moves), "move_ms_max": max(moves),
               "longest_pause_ms": max(s["longest_pause_ms"] for s in result["strokes"]),
               "stored_s": [s["stored_s"] for s in result["strokes"]], "raw": result}
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / ("%s.json" % args.out)).write_text(json.dumps(summary, indent=1))
    print("Sculpt mode on %d triangles (brush radius %.2f): mouse moves during a drag %.0f ms median, %.0f ms at "
          "most; from the release to the stored stroke %s s, the event loop's longest pause %.0f ms."
          % (summary["triangles"], summary["radius"], summary["move_ms_median"], summary["move_ms_max"],
             ", ".join("%.2f" % s for s in summary["stored_s"]), summary["longest_pause_ms"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
