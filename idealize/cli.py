"""Command line: python -m idealize convert INPUT -o OUT.step --report REPORT.json"""
import argparse
import sys
import time

from .brep import make_solid
from .features import count_summary, idealize
from .mesh import MeshError, load_mesh
from .report import build_report, write_report

# Exit codes: 0 a valid solid was written; 1 only the faces that could be made were written (the
# report's "brep.problems" says which features failed); 2 bad input.
EXIT_NOT_SOLID = 1


def convert(args):
    timings = {}
    start = time.perf_counter()
    mesh = load_mesh(args.input)
    timings["load"] = time.perf_counter() - start
    layer = idealize(mesh, self_intersections=True)  # the report's mesh check counts them
    for stage, seconds in layer.segmentation.timings.items():
        timings["segment." + stage] = seconds
    timings["segment"] = sum(layer.segmentation.timings.values())
    feature_stages = {k: v for k, v in layer.timings.items() if k.startswith("features.")}
    timings.update(feature_stages)
    timings["features"] = sum(feature_stages.values())
    solid = make_solid(layer)
    timings.update(solid.timings)
    step = {"written": False, "path": None}
    if solid.faces:
        stage = time.perf_counter()
        solid.write_step(args.output)
        timings["step"] = time.perf_counter() - stage
        step = {"written": True, "path": args.output, "solid": bool(solid.solid)}
    else:
        step["reason"] = "no face could be made"
    timings["total"] = time.perf_counter() - start
    report = build_report(mesh, layer, timings, step, solid)
    if args.report:
        write_report(report, args.report)
    print("%s: %d triangles (%s, noise %.3g), %d features (%s), %.3f s"
          % (args.input, mesh.n_triangles, layer.mesh_kind, layer.noise, len(layer.features),
             count_summary(layer.type_counts()), timings["total"]))
    if solid.solid:
        print("solid: %d faces (%s), volume %.6g, written to %s"
              % (solid.faces, count_summary(solid.surface_types), solid.volume, args.output))
    else:
        print("warning: no valid closed solid; %s" % ("%d faces written to %s" % (solid.faces, args.output)
                                                      if solid.faces else "no STEP file written"), file=sys.stderr)
        for feature, message in solid.problems:
            print("  %s: %s" % ("feature %d" % feature if feature >= 0 else "shape", message), file=sys.stderr)
    if args.report:
        print("report written to %s" % args.report)
    return 0 if solid.solid else EXIT_NOT_SOLID


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m idealize",
                                     description="Turn a triangle mesh of a mechanical part into features and CAD.")
    commands = parser.add_subparsers(dest="command", required=True)
    p = commands.add_parser("convert", help="turn a mesh into a fitted solid (STEP) and a report")
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
