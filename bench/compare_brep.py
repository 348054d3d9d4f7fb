"""Valid solids and analytic area over every part of the test data and every real mesh, for this
checkout and a baseline checkout, two meshes at a time (one subprocess each, with a time limit):
wins and losses part by part.

    /usr/bin/python3 bench/compare_brep.py --baseline /tmp/base            # both, then the table
    /usr/bin/python3 bench/compare_brep.py --only box --variant scan       # a subset, this checkout
    /usr/bin/python3 bench/compare_brep.py --table new.json old.json       # the table of two runs
    /usr/bin/python3 bench/compare_brep.py --identical new.json old.json   # meshes whose results differ

The baseline is another checkout with its native module built (for example `git worktree add
/tmp/base <rev>` and `cmake -S /tmp/base -B /tmp/base/build && cmake --build /tmp/base/build`).
Results go to bench/results/compare-brep-*.json and the table to standard output.
"""
from __future__ import annotations

import argparse
import collections
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

BENCH = Path(__file__).resolve().parent
REPO = BENCH.parent
RESULTS = BENCH / "results"
sys.path.insert(0, str(BENCH))
import datasets  # noqa: E402  (numpy only; FreeCAD is loaded when a mesh is made)


def one(repo: str, kind: str, name: str, variant: str) -> None:
    """Convert one mesh with the checkout at `repo`; prints one JSON row."""
    sys.path.insert(0, repo)
    import idealize
    if kind == "real":
        mesh = idealize.load_mesh(name)
    else:
        messages = []
        meshes = datasets.load_part(datasets.step_files_by_name()[name], [variant], log=messages.append)
        if not meshes:  # the data set skips it (a marching-cubes surface that loses thin walls)
            print("ROW " + json.dumps({"skipped": (messages or ["no mesh"])[-1]}))
            return
        mesh = idealize.Mesh(meshes[0].V, meshes[0].F)
    start = time.perf_counter()
    layer = idealize.idealize(mesh)
    identified = time.perf_counter()
    solid = idealize.make_solid(layer)
    row = dict(solid=bool(solid.solid), valid=bool(solid.valid), closed=bool(solid.closed), faces=int(solid.faces),
               features=len(layer.features), volume=float(solid.volume), identify=identified - start,
               brep=float(solid.timings["brep"]))
    if hasattr(solid, "regions"):
        row["aaf"] = solid.analytic_area_fraction
        row["kinds"] = {k: sum(r["kind"] == k for r in solid.regions) for k in ("analytic", "bspline", "faceted")}
    if hasattr(solid, "euler"):
        row["euler"] = solid.euler
    if hasattr(solid, "deviation_bound"):  # honest validity, relative to the mesh's diagonal
        import numpy as np
        diagonal = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
        row.update(mesh_to_solid=solid.mesh_to_shape / diagonal, solid_to_mesh=solid.shape_to_mesh / diagonal,
                   bound=solid.deviation_bound / diagonal, mesh_volume=solid.mesh_volume)
    row.update(fingerprint(layer, solid))
    print("ROW " + json.dumps(row))


def fingerprint(layer, solid) -> dict:
    """Hashes of everything the feature layer and the solid hold, to show that a change of the code
    changed no result (`--identical`): labels, idealized vertices, features, adjacency and
    relations bit for bit, and the shape's BRep text."""
    import hashlib
    import numpy as np
    h = hashlib.sha1()
    h.update(np.ascontiguousarray(layer.labels, dtype=np.int64).tobytes())
    h.update(np.ascontiguousarray(layer.idealized_vertices, dtype=np.float64).tobytes())

    def plain(x):  # JSON of numpy values, floats as their exact repr
        if isinstance(x, dict):
            return {str(k): plain(v) for k, v in sorted(x.items())}
        if isinstance(x, (list, tuple)) or isinstance(x, np.ndarray):
            return [plain(v) for v in (x.tolist() if isinstance(x, np.ndarray) else x)]
        if isinstance(x, (float, np.floating)):
            return repr(float(x))
        if isinstance(x, (np.integer,)):
            return int(x)
        return x
    h.update(json.dumps(plain([layer.features, layer.adjacency, layer.relations])).encode())
    return dict(layer_hash=h.hexdigest(), solid_hash=hashlib.sha1(solid.brep_string()).hexdigest())


def identical(new, old) -> str:
    """The meshes whose feature layer or solid differ between two runs (hashes from `fingerprint`)."""
    base = {(r["name"], r["variant"]): r for r in old}
    lines, same = [], 0
    for r in sorted(new, key=lambda r: (r["name"], datasets.variant_order(r["variant"]))):
        b = base.get((r["name"], r["variant"]))
        if b is None:
            lines.append(f"{r['name']} {r['variant']}: not in the old run")
            continue
        what = [k for k in ("layer_hash", "solid_hash", "error") if r.get(k) != b.get(k)]
        if what:
            lines.append(f"{r['name']} {r['variant']}: differs in " + ", ".join(what))
        else:
            same += 1
    return "\n".join([f"{same} of {len(new)} meshes identical (feature layer and solid)"] + lines)


def run(repo: str, tasks, timeout: float):
    def convert(task):
        started = time.time()
        try:
            done = subprocess.run([sys.executable, __file__, "--one", repo, *task], capture_output=True, text=True,
                                  timeout=timeout)
            rows = [line[4:] for line in done.stdout.splitlines() if line.startswith("ROW ")]
            row = json.loads(rows[0]) if rows else {"error": (done.stderr.strip().splitlines() or ["?"])[-1][:200]}
        except subprocess.TimeoutExpired:
            row = {"error": "timeout"}
        row.update(kind=task[0], name=os.path.basename(task[1]), variant=task[2], seconds=time.time() - started)
        print(json.dumps(row), flush=True)
        return row

    with ThreadPoolExecutor(2) as pool:
        return list(pool.map(convert, tasks))


def changed(r, b) -> bool:
    """Whether a mesh's result differs between two runs: solid or not, kinds of faces, analytic area."""
    return (bool(r.get("solid")) != bool(b.get("solid")) or r.get("kinds") != b.get("kinds")
            or abs(r.get("aaf", 0) - b.get("aaf", 0)) > 1e-3)


def table(new, old, only_changed=False) -> str:
    base = {(r["name"], r["variant"]): r for r in old}
    agg = collections.defaultdict(collections.Counter)
    lines = ["| part | variant | before | after | analytic area | regions analytic / bspline / faceted | B-rep s before / after |",
             "|---|---|---|---|---|---|---|"]
    state = lambda r: "error" if "error" in r else "skipped" if "skipped" in r else (  # noqa: E731
        "solid" if r.get("solid") else "no")
    for r in sorted(new, key=lambda r: (r["name"], datasets.variant_order(r["variant"]))):
        b = base.get((r["name"], r["variant"]), {})
        a = agg[r["variant"]]
        if "skipped" in r:
            a["skipped"] += 1
            continue
        a["meshes"] += 1
        a["before"] += bool(b.get("solid"))
        a["after"] += bool(r.get("solid"))
        a["won"] += bool(r.get("solid")) and not b.get("solid")
        a["lost"] += bool(b.get("solid")) and not r.get("solid")
        a["99"] += bool(r.get("solid")) and r.get("aaf", 0) >= 0.99
        a["90"] += bool(r.get("solid")) and r.get("aaf", 0) >= 0.90
        k = r.get("kinds") or {}
        if only_changed and not changed(r, b):
            continue
        lines.append(f"| {r['name']} | {r['variant']} | {state(b)} | {state(r)} | {100 * r.get('aaf', 0):.1f} % | "
                     f"{k.get('analytic', '')} / {k.get('bspline', '')} / {k.get('faceted', '')} | "
                     f"{b.get('brep', 0):.2f} / {r.get('brep', 0):.2f} |")
    summary = ["| variant | meshes | valid closed solid before | after | won | lost | after, >= 99 % / >= 90 % of the area analytic |",
               "|---|---|---|---|---|---|---|"]
    for v in (*datasets.VARIANTS, "real"):
        a = agg[v]
        if a["meshes"]:
            summary.append(f"| {v} | {a['meshes']}" + (f" ({a['skipped']} skipped)" if a["skipped"] else "")
                           + f" | {a['before']} | {a['after']} | {a['won']} | {a['lost']} | {a['99']} / {a['90']} |")
    return "\n".join(summary + [""] + lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--one", nargs=4, help=argparse.SUPPRESS)
    parser.add_argument("--baseline", help="another checkout to run in the same run")
    parser.add_argument("--checkout", default=str(REPO), help="the checkout to measure (default this one; a copy "
                        "lets the run go on while this one is rebuilt)")
    parser.add_argument("--only", action="append", metavar="NAME")
    parser.add_argument("--variant", action="append", choices=datasets.VARIANTS)
    parser.add_argument("--real", action="store_true", help="the real meshes too (with --variant or --only)")
    parser.add_argument("--timeout", type=float, default=900, help="seconds per mesh")
    parser.add_argument("--out", default="compare-brep-new.json", help="file name of this checkout's results "
                        "under bench/results/")
    parser.add_argument("--table", nargs=2, metavar=("NEW", "OLD"))
    parser.add_argument("--changed", action="store_true", help="with --table: only the meshes whose result changed")
    parser.add_argument("--identical", nargs=2, metavar=("NEW", "OLD"),
                        help="list the meshes whose feature layer or solid differ bit for bit between two runs")
    args = parser.parse_args()
    if args.one:
        one(*args.one)
        return 0
    if args.identical:
        print(identical(json.loads(Path(args.identical[0]).read_text()), json.loads(Path(args.identical[1]).read_text())))
        return 0
    if args.table:
        print(table(json.loads(Path(args.table[0]).read_text()), json.loads(Path(args.table[1]).read_text()),
                    args.changed))
        return 0
    tasks = [("part", name, v) for name in sorted(datasets.step_files_by_name())
             if not args.only or any(k in name for k in args.only) for v in (args.variant or datasets.VARIANTS)]
    if args.real or (not args.only and not args.variant):
        tasks += [("real", m["path"], "real") for m in datasets.load_real_meshes()]
    RESULTS.mkdir(parents=True, exist_ok=True)
    new = run(args.checkout, tasks, args.timeout)
    (RESULTS / args.out).write_text(json.dumps(new, indent=0))
    old = []
    if args.baseline:
        old = run(args.baseline, tasks, args.timeout)
        (RESULTS / "compare-brep-baseline.json").write_text(json.dumps(old, indent=0))
    print(table(new, old))
    return 0


if __name__ == "__main__":
    sys.exit(main())
