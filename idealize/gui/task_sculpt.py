"""Sculpt mode (Resources/ui/Sculpt.ui; issue 53): drags with the left mouse button on a feature
layer in the 3D view apply the chosen brush (idealize.sculpt) along the stroke, seen from the view's
direction; a circle under the pointer shows the brush.

The clay moves under the pointer: the panel keeps a Sculptor, each mouse move adds the stroke's
dabs up to the new point, and a preview draws the mesh as it is (faces not re-idealized yet in the
freeform grey) in place of the layer.

Each stroke is one undo step: the layer's sculpt edit, re-idealized (idealize.reidealize), and the
solids made from its source regenerated. The stroke's replay, its re-idealization and the
preparation of what the layer object stores run in a worker thread (the core API is free of
FreeCAD, and its native parts release the interpreter), so the view stays interactive; strokes made
meanwhile wait their turn, and each is stored, in the GUI's thread, when its result is ready. The
replay makes the same dabs as the drag did (idealize.sculpt.Sculptor.begin), so the stored stroke is
the one seen. Once every stroke is stored, the layer is shown again, re-idealized.
With re-idealization after each stroke turned off, the strokes are applied together, as one step,
when the panel closes. Close or Esc leaves the mode.
"""
import math
import os
import threading

import FreeCADGui
import numpy as np

from .. import sculpt
from ..freecad import layer_object
from ..freecad.mesh import SURFACE_COLORS, type_colors
from .task_push_pull import Preview, apply_in_one_step

UI_FILE = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                       "Resources", "ui", "Sculpt.ui")
CIRCLE_SEGMENTS = 48  # the brush circle's polygon: smooth at any size on screen
POLL_MS = 30  # how often the GUI looks for a finished stroke: well below what a user notices
# The preview of the clay under the pointer is drawn again at most this often: drawing a 100k-triangle
# mesh takes about 50 ms, and a drag's moves come every 10-20 ms (a refresh per move would queue them).
REFRESH_MS = 60

#: The panel open now (None when none is): for macros and tests.
active_panel = None


def default_radius(layer):
    """Four times the layer's median edge length: a brush a few triangles wide."""
    V, F = layer.idealized_vertices, layer.mesh.faces
    lengths = np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1)
    return float(4.0 * np.median(lengths)) if len(lengths) else 1.0


class BrushCircle:
    """The brush's outline: a circle of the radius at the picked point, across the view direction."""

    def __init__(self, view):
        from pivy import coin
        self.view = view
        self.node = coin.SoSeparator()
        self.transform = coin.SoTransform()
        color = coin.SoBaseColor()
        color.rgb.setValue(1.0, 0.55, 0.0)
        style = coin.SoDrawStyle()
        style.lineWidth = 2
        points = coin.SoCoordinate3()
        angles = np.linspace(0.0, 2.0 * math.pi, CIRCLE_SEGMENTS + 1)
        points.point.setValues(0, len(angles), [[math.cos(a), math.sin(a), 0.0] for a in angles])
        lines = coin.SoLineSet()
        lines.numVertices.setValue(len(angles))
        for child in (self.transform, color, style, points, lines):
            self.node.addChild(child)
        self.shown = False

    def show(self, point, direction, radius):
        from pivy import coin
        self.transform.translation.setValue(*[float(x) for x in point])
        self.transform.rotation.setValue(coin.SbRotation(coin.SbVec3f(0, 0, 1), coin.SbVec3f(*[float(-x) for x in direction])))
        self.transform.scaleFactor.setValue(radius, radius, radius)
        if not self.shown:
            self.view.getSceneGraph().addChild(self.node)
            self.shown = True

    def hide(self):
        if self.shown:
            self.view.getSceneGraph().removeChild(self.node)
            self.shown = False


def ReleaseFilter(ended):
    """A Qt event filter that calls ended() on a left-button release (and lets the event through)."""
    from PySide import QtCore

    class Filter(QtCore.QObject):
        def eventFilter(self, watched, event):
            if event.type() == QtCore.QEvent.MouseButtonRelease and event.button() == QtCore.Qt.LeftButton:
                QtCore.QTimer.singleShot(0, ended)  # after the view has seen the release
            return False

    return Filter()


class SculptPanel:
    def __init__(self, obj):
        global active_panel
        from pivy import coin
        self.obj = obj
        self.layer = layer_object.feature_layer(obj)
        self.form = FreeCADGui.PySideUic.loadUi(UI_FILE)
        for brush in sculpt.BRUSHES:
            self.form.brush.addItem(brush.capitalize(), brush)
        self.form.radius.setValue(default_radius(self.layer))
        self.view = FreeCADGui.getDocument(obj.Document.Name).ActiveView
        self.circle = BrushCircle(self.view)
        self.preview = Preview(obj)
        self.pending = []     # strokes kept for one re-idealization when the panel closes
        self.stroke = None    # (points, directions) of the drag under way
        self.strokes_applied = 0
        self.queue = []       # strokes waiting for the worker
        self.job = None       # the worker's (thread, step, the layer's Edits when it started, outcome)
        self.timer = None
        self.source = None    # the source mesh, read once
        self.layer_edits = getattr(obj, "Edits", "")  # the object's Edits that self.layer has
        self.sculptor = None  # the clay under the pointer: a Sculptor of sculptor_layer
        self.sculptor_layer = None
        self.sculptor_stale = True  # the layer has changed since: start again from it when idle
        self.ready_sculptor = None  # (layer, a Sculptor of it) made by the worker for the next stroke
        self.refresh_timer = None
        self.callbacks = [
            (coin.SoMouseButtonEvent.getClassTypeId(), self.view.addEventCallbackPivy(
                coin.SoMouseButtonEvent.getClassTypeId(), self.on_button)),
            (coin.SoLocation2Event.getClassTypeId(), self.view.addEventCallbackPivy(
                coin.SoLocation2Event.getClassTypeId(), self.on_move)),
        ]
        # The button's release reaches the view's navigation first, which takes it: the stroke ends
        # on the widget's own release event instead.
        self.viewport = self.view.graphicsView().viewport()
        self.release_filter = ReleaseFilter(self.end_stroke)
        self.viewport.installEventFilter(self.release_filter)
        active_panel = self

    def getStandardButtons(self):
        from PySide import QtGui
        return int(QtGui.QDialogButtonBox.Close)

    # The view's events.
    def pick(self, position):
        """The point of the layer (or of the clay drawn in its place) under the screen position,
        or None."""
        if self.preview.shown and self.sculptor is not None:
            return self.sculptor.first_hit(*self.ray(position))
        info = self.view.getObjectInfo((int(position[0]), int(position[1])))
        if not info or info.get("Object") != self.obj.Name:
            return None
        return np.array([info["x"], info["y"], info["z"]], dtype=float)

    def ray(self, position):
        """The view's ray through the screen position, towards the scene: (origin, direction)."""
        on_plane = self.view.getPointOnFocalPlane(int(position[0]), int(position[1]))
        point = np.array([on_plane.x, on_plane.y, on_plane.z], dtype=float)
        if self.view.getCameraType() == "Perspective":
            eye = np.array(self.view.getCameraNode().position.getValue(), dtype=float)
            return eye, point - eye
        # Orthographic: from behind everything shown (the focal plane may cut the part).
        V = self.layer.idealized_vertices
        low, high = V.min(axis=0), V.max(axis=0)
        reach = np.linalg.norm(high - low) + np.linalg.norm(point - 0.5 * (low + high))
        return point - 2.0 * reach * self.direction(), self.direction()

    def direction(self):
        d = self.view.getViewDirection()
        return np.array([d.x, d.y, d.z], dtype=float)

    def on_move(self, callback):
        event = callback.getEvent()
        point = self.pick(event.getPosition().getValue())
        if point is None:
            self.circle.hide()
            return
        self.circle.show(point, self.direction(), self.form.radius.value())
        if self.stroke is not None:
            self.stroke[0].append(point.tolist())
            self.stroke[1].append(self.direction().tolist())
            callback.setHandled()
            if self.sculptor is not None:
                self.sculptor.extend([point], [self.direction()])
                self.schedule_refresh()

    def on_button(self, callback):
        from pivy import coin
        event = callback.getEvent()
        if event.getButton() != coin.SoMouseButtonEvent.BUTTON1:
            return
        if event.getState() == coin.SoButtonEvent.DOWN:
            point = self.pick(event.getPosition().getValue())
            if point is None:
                return  # off the mesh: the view turns as usual
            self.stroke = ([point.tolist()], [self.direction().tolist()])
            callback.setHandled()
            self.begin_live(point, self.direction())
        elif self.stroke is not None:
            callback.setHandled()
            self.end_stroke()

    def end_stroke(self):
        if self.stroke is None:
            return
        points, directions = self.stroke
        self.stroke = None
        if self.sculptor is not None:
            self.sculptor.end()
            self.refresh()
        self.finish(points, directions)

    # The clay under the pointer.
    def begin_live(self, point, direction):
        """Starts the stroke's dabs on the panel's Sculptor: from the layer as it is stored when
        nothing is waiting to be stored (after an undo too), else on from the strokes before."""
        if getattr(self.obj, "Edits", "") != self.layer_edits and not self.busy and not self.pending:
            self.layer, self.layer_edits = layer_object.feature_layer(self.obj), getattr(self.obj, "Edits", "")
            self.sculptor_stale = True
        try:
            if self.sculptor is None or (self.sculptor_stale and not self.busy and not self.pending):
                ready, self.ready_sculptor = self.ready_sculptor, None
                if ready is None or ready[0] is not self.layer:
                    ready = (self.layer, sculpt.Sculptor(self.layer))
                self.sculptor_layer, self.sculptor = ready
                self.sculptor_stale = False
            step = self.stroke_step([point.tolist()], [direction.tolist()])
            self.sculptor.begin(step["brush"], point, direction, radius=step["radius"], strength=step["strength"])
        except Exception as error:  # the stroke is dropped on release, and said so
            self.sculptor, self.stroke = None, None
            self.form.status.setText("Cannot sculpt here: %s" % error)
            return
        # The layer is hidden while the clay shows: not left highlighted as the pointer found it.
        FreeCADGui.Selection.clearPreselection()
        self.refresh()

    def schedule_refresh(self):
        from PySide import QtCore
        if self.refresh_timer is None:
            self.refresh_timer = QtCore.QTimer()
            self.refresh_timer.setSingleShot(True)
            self.refresh_timer.timeout.connect(self.refresh)
        if not self.refresh_timer.isActive():
            self.refresh_timer.start(REFRESH_MS)

    def refresh(self):
        """Draws the Sculptor's mesh in place of the layer: faces carry their feature's colour, those
        sculpted and not re-idealized yet the freeform grey."""
        if self.refresh_timer is not None:
            self.refresh_timer.stop()
        if self.sculptor is None:
            return
        mesh = self.sculptor.mesh()
        colors = type_colors(self.sculptor_layer.features, self.sculptor.labels())
        colors[self.sculptor.modified()] = SURFACE_COLORS["freeform"]
        self.preview.show_mesh(mesh.vertices, mesh.faces, colors)

    def show_stored(self):
        """Once every stroke is stored and none is under way: the layer again, re-idealized."""
        if not self.busy and self.stroke is None and not self.pending:
            if self.preview.shown:
                self.preview.hide()
            self.sculptor_stale = True

    # Strokes.
    def stroke_step(self, points, directions):
        return {"brush": self.form.brush.currentData(), "points": points, "directions": directions,
                "radius": float(self.form.radius.value()), "strength": float(self.form.strength.value())}

    def finish(self, points, directions):
        one = self.stroke_step(points, directions)
        if not self.form.reidealize.isChecked():
            self.pending.append(one)
            self.form.status.setText("%d strokes waiting: re-idealized when the panel closes." % len(self.pending))
            return
        if self.pending:  # made with re-idealization off, before this one: stored first, as one step
            self.queue.append({"op": "sculpt", "strokes": self.pending})
            self.pending = []
        self.queue.append({"op": "sculpt", "strokes": [one]})
        self.start_next()

    # The worker.
    @property
    def busy(self):
        """Whether strokes are still being sculpted and re-idealized."""
        return self.job is not None or bool(self.queue)

    def start_next(self):
        """Starts the next waiting stroke in a worker thread, from the layer as it is now."""
        from PySide import QtCore
        if self.job is not None or not self.queue:
            return
        step, outcome = self.queue.pop(0), {}
        if self.source is None:
            self.source = layer_object.source_mesh(self.obj)  # it does not change while sculpting
        if getattr(self.obj, "Edits", "") != self.layer_edits:  # undone or redone meanwhile
            self.layer, self.layer_edits = layer_object.feature_layer(self.obj), getattr(self.obj, "Edits", "")
        # Read here: the document belongs to this thread.
        inputs = layer_object.edit_inputs(self.obj, self.layer, self.source)

        def work():
            try:
                outcome["record"] = layer_object.edit_record(inputs, step)
                # The next stroke's clay, made here rather than at its press.
                outcome["sculptor"] = sculpt.Sculptor(outcome["record"].layer)
            except Exception as error:  # reported in the GUI's thread
                outcome["error"] = error
        thread = threading.Thread(target=work, name="Idealize sculpt", daemon=True)
        self.job = (thread, step, getattr(self.obj, "Edits", ""), outcome)
        self.form.status.setText("Re-idealizing the stroke...")
        thread.start()
        if self.timer is None:
            self.timer = QtCore.QTimer()
            self.timer.timeout.connect(self.poll)
        self.timer.start(POLL_MS)

    def poll(self, wait=False):
        """Stores the worker's result once it is ready (at once with `wait`), then starts the next."""
        if self.job is None:
            return
        thread, step, edits, outcome = self.job
        if wait:
            thread.join()
        if thread.is_alive():
            return
        self.job = None
        if self.timer is not None:
            self.timer.stop()
        if "error" in outcome:
            from .commands import report_error
            report_error("Sculpt stroke", outcome["error"])
        else:
            # Computed from the layer as it was: stored as is unless the object changed meanwhile
            # (an undo), when it is computed again from the object's layer.
            edited = outcome["record"] if getattr(self.obj, "Edits", "") == edits else None
            done = apply_in_one_step(self.obj, step, "Sculpt stroke", edited)
            if done is not None:
                self.layer, self.layer_edits = done[0], getattr(self.obj, "Edits", "")
                if edited is not None and done[0] is edited.layer:
                    self.ready_sculptor = (done[0], outcome["sculptor"])
                self.strokes_applied += 1
                new = sum(1 for f in self.layer.features if f["triangles"])
                self.form.status.setText("%d strokes; the layer has %d features." % (self.strokes_applied, new))
        self.sculptor_stale = True
        self.start_next()
        self.show_stored()

    # Leaving.
    def close(self):
        global active_panel
        for kind, callback in self.callbacks:
            self.view.removeEventCallbackPivy(kind, callback)
        self.callbacks = []
        self.viewport.removeEventFilter(self.release_filter)
        self.circle.hide()
        if self.stroke is not None:  # a drag under way when the panel closes: stored as it is
            self.end_stroke()
        if self.refresh_timer is not None:
            self.refresh_timer.stop()
        self.preview.hide()
        while self.busy:  # the strokes made are all stored
            self.poll(wait=True)
        if self.timer is not None:
            self.timer.stop()
        if self.pending:
            apply_in_one_step(self.obj, {"op": "sculpt", "strokes": self.pending}, "Sculpt")
            self.pending = []
        active_panel = None
        FreeCADGui.Control.closeDialog()
        return True

    def accept(self):
        return self.close()

    def reject(self):
        return self.close()
