"""How soon a cancelled B-rep construction (idealize.make_solid) returns, stage by stage.

For each mesh the feature layer is made once; then make_solid runs once to time its stages, and
again and again in a worker thread, cancelled at evenly spread moments of that time. The latency is
the time from Progress.cancel() to the worker's return (Cancelled); the table gives the largest per
stage. The issue asks for at most 1 s in every stage.

    /usr/bin/python3 bench/cancel_latency.py                      # the default meshes
    /usr/bin/python3 bench/cancel_latency.py --points 10 --only joint

Results go to bench/results/cancel.json and the table to standard output.
"""
from __future__ import annotations

import argparse
import collections
import json
import sys
import threading
import time
from pathlib import Path

BENCH = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH.parent))
sys.path.insert(1, str(BENCH))

# A CAD tessellation (analytic faces), a scan-like mesh whose B-rep degrades to thousands of facets,
# and real meshes of about 25k triangles.
MESHES = [("part", "as_chamfer_2.stp", "cad"), ("part", "as_chamfer_2.stp", "scan"),
          ("real", "joint.stl", "real"), ("real", "casting.stl", "real")]


def load(kind, name, variant):
    import idealize
    if kind == "real":
        return idealize.load_mesh(str(BENCH.parent.parent / "shared" / "data" / "mesh" / name))
    import datasets
    m = datasets.load_part(datasets.step_files_by_name()[name], [variant], log=lambda s: None)[0]
    return idealize.Mesh(m.V, m.F)


def run(layer, cancel_at=None):
    """One make_solid in a worker thread: (stage timeline, (stage, latency) or None)."""
    import idealize
    progress = idealize.Progress()
    ended = {}

    def work():
        try:
            idealize.make_solid(layer, progress=progress)
        except idealize.Cancelled:
            pass
        ended["at"] = time.perf_counter()

    worker = threading.Thread(target=work)
    start = time.perf_counter()
    worker.start()
    timeline, cancelled = [], None
    while worker.is_alive():
        now = time.perf_counter() - start
        timeline.append((now, progress.stage))
        if cancel_at is not None and cancelled is None and now >= cancel_at:
            stage = progress.stage
            progress.cancel()
            cancelled = (stage, time.perf_counter())
        time.sleep(0.002)
    worker.join()
    if cancelled is None:
        return timeline, None
    return timeline, (cancelled[0], ended["at"] - cancelled[1])


def measure(kind, name, variant, points):
    import idealize
    layer = idealize.idealize(load(kind, name, variant))
    timeline, _ = run(layer)
    total = timeline[-1][0] if timeline else 0.0
    worst = collections.defaultdict(float)
    for k in range(1, points + 1):
        _, hit = run(layer, total * k / (points + 1))
        if hit:
            worst[hit[0] or "start"] = max(worst[hit[0] or "start"], hit[1])
    return {"mesh": f"{name} ({variant})", "seconds": total, "worst": dict(worst)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--points", type=int, default=20, help="cancellations per mesh")
    parser.add_argument("--only", action="append", metavar="NAME")
    args = parser.parse_args()
    rows = [measure(*m, args.points) for m in MESHES if not args.only or any(k in m[1] for k in args.only)]
    (BENCH / "results").mkdir(exist_ok=True)
    (BENCH / "results" / "cancel.json").write_text(json.dumps(rows, indent=1))
    stages = sorted({s for r in rows for s in r["worst"]})
    print("| mesh | make_solid s | " + " | ".join(stages) + " |")
    print("|---|---|" + "---|" * len(stages))
    for r in rows:
        print(f"| {r['mesh']} | {r['seconds']:.1f} | " +
              " | ".join(f"{r['worst'][s]:.2f}" if s in r["worst"] else "" for s in stages) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
