"""Progress reporting and cancellation for the long calls (segment, idealize, make_solid).

A GUI runs the computation in a worker thread and shows the progress from its own thread::

    progress = idealize.Progress()
    worker = threading.Thread(target=lambda: idealize.idealize(mesh, progress=progress))
    worker.start()
    ...                       # in the GUI thread, on a timer:
    progress.fraction         # 0..1 over the whole call, never decreasing
    progress.stage            # the step running now ("denoise", "merge", ...)
    progress.cancel()         # the call raises idealize.Cancelled soon after (well under a second)

The native code releases the GIL while it runs and reads the Progress without it. A result
computed with a Progress is the same as without. ``set_range(start, end)`` lets the next call fill
only part of the bar (for several calls under one bar); ``range`` reads it back.
"""
from ._loader import native

Progress = native.Progress
_native_cancel = native.Progress.cancel


def _cancel(self):
    """Ask the computation to stop; it raises Cancelled soon after."""
    _native_cancel(self)


# cancel() as a Python function, so that a Qt signal can be connected to it directly (the GUI's
# Cancel button): PySide2 5.15 crashes connecting a signal to a method of a compiled class.
Progress.cancel = _cancel

Cancelled = native.Cancelled
Cancelled.__doc__ = "The computation was cancelled through its Progress; nothing was returned."
