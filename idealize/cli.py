"""Command line: python -m idealize convert INPUT -o OUT.step --report REPORT.json"""
import argparse
import sys
import time

from .features import idealize
from .mesh import MeshError, load_mesh
from .report import build_report, write_report

NO_STEP_YET = ("no STEP file was written: B-rep construction and STEP export are not implemented "
               "yet; this version stops after feature identification")


def convert(args):
    timings = {}
    start = time.perf_counter()
    mesh = load_mesh(args.input)
    timings["load"] = time.perf_counter() - start
    layer = idealize(mesh)
    for stage, seconds in layer.segmentation.timings.items():
        timings["segment." + stage] = seconds
    timings["segment"] = sum(layer.segmentation.timings.values())
    feature_stages = {k: v for k, v in layer.timings.items() if k.startswith("features.")}
    timings.update(feature_stages)
    timings["features"] = sum(feature_stages.values())
    timings["total"] = time.perf_counter() - start
    step = {"written": False, "path": None, "reason": NO_STEP_YET}
    report = build_report(mesh, layer, timings, step)
    if args.report:
        write_report(report, args.report)
    kinds = ", ".join("%d %s" % (n, t) for t, n in sorted(layer.type_counts().items()))
    print("%s: %d triangles, %d features (%s), %.3f s"
          % (args.input, mesh.n_triangles, len(layer.features), kinds, timings["total"]))
    if args.report:
        print("report written to %s" % args.report)
    print("note: " + NO_STEP_YET + " (%s not created)" % args.output, file=sys.stderr)
    return 0


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m idealize",
                                     description="Turn a triangle mesh of a mechanical part into features and CAD.")
    commands = parser.add_subparsers(dest="command", required=True)
    p = commands.add_parser("convert", help="find the features of a mesh and write a report")
    p.add_argument("input", help="STL, OBJ, OFF or PLY file")
    p.add_argument("-o", "--output", required=True, help="STEP file to write")
    p.add_argument("--report", help="JSON report to write")
    args = parser.parse_args(argv)
    try:
        return convert(args)
    except MeshError as error:
        print("error: %s" % error, file=sys.stderr)
        return 2
    except OSError as error:
        print("error: %s" % error, file=sys.stderr)
        return 2
