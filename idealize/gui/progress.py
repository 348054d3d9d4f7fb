"""Long native calls in a worker thread, with a progress dialog and a Cancel button.

The native core releases the GIL and polls the cancel flag of its Progress object, so the GUI
thread keeps the event loop turning while it works. Document changes stay in the GUI thread.
"""
import threading
import time

import FreeCADGui

from ..progress import Cancelled, Progress

# The dialog appears only for calls longer than this (seconds): shorter ones would flash.
SHOW_AFTER = 0.5


def run_with_progress(title, function, *args, **kwargs):
    """function(*args, progress=..., **kwargs) in a worker thread; returns its result or raises
    its exception (idealize.Cancelled when the user cancelled)."""
    from PySide import QtCore, QtGui
    progress = Progress()
    outcome = {}

    def work():
        try:
            outcome["result"] = function(*args, progress=progress, **kwargs)
        except BaseException as error:  # handed to the GUI thread, which raises it
            outcome["error"] = error

    dialog = QtGui.QProgressDialog(title, "Cancel", 0, 1000, FreeCADGui.getMainWindow())
    dialog.setWindowTitle("Idealize")
    dialog.setWindowModality(QtCore.Qt.WindowModal)
    dialog.setAutoClose(False)
    dialog.setAutoReset(False)
    dialog.setMinimumDuration(1 << 30)  # shown by the loop below, not by Qt's estimate
    dialog.canceled.connect(progress.cancel)
    worker = threading.Thread(target=work, name="idealize: " + title, daemon=True)
    start = time.perf_counter()
    worker.start()
    try:
        while worker.is_alive():
            worker.join(0.03)
            if not dialog.isVisible() and time.perf_counter() - start > SHOW_AFTER:
                dialog.show()
            if dialog.wasCanceled():  # also when cancelled by Esc or programmatically (no signal then)
                progress.cancel()
            elif dialog.isVisible():
                dialog.setLabelText("%s: %s" % (title, progress.stage or "starting"))
                dialog.setValue(int(1000 * progress.fraction))
            QtGui.QApplication.processEvents()
    finally:
        if worker.is_alive():  # the event loop raised (e.g. KeyboardInterrupt): stop the worker
            progress.cancel()
            worker.join()
        # Read before close(): closing a QProgressDialog emits canceled (progress.cancel) too.
        cancelled = progress.cancelled or dialog.wasCanceled()
        dialog.close()
        dialog.deleteLater()
    if cancelled and not isinstance(outcome.get("error"), Cancelled):
        # Cancel pressed after the worker's last look at the flag (it finished meanwhile, or it
        # was in a step that does not poll): the user asked for nothing, so nothing is returned.
        raise Cancelled("%s cancelled" % title)
    if "error" in outcome:
        raise outcome["error"]
    return outcome["result"]
