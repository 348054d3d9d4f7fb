// Unit tests of the B-rep's geometry (native/src/brep/): closed-form intersections, corner solves,
// pcurves, the validity and deviation checks. Run by ctest (tools/test.sh); no framework, each
// CHECK prints where it failed and the exit status counts the failures.
#include "brep/checks.h"
#include "brep/corners.h"
#include "brep/curves.h"
#include "brep/deviation.h"
#include "brep/surfaces.h"
#include "brep/validity.h"

#include <BRepBuilderAPI_MakeEdge.hxx>
#include <BRepBuilderAPI_MakeFace.hxx>
#include <BRepBuilderAPI_MakeVertex.hxx>
#include <BRep_Builder.hxx>
#include <TopExp.hxx>
#include <TopoDS_Shell.hxx>
#include <BRepBuilderAPI_MakeWire.hxx>
#include <BRepLib_CheckCurveOnSurface.hxx>
#include <BRepAlgoAPI_Cut.hxx>
#include <BRepPrimAPI_MakeBox.hxx>
#include <BRepPrimAPI_MakeCylinder.hxx>
#include <BRepPrimAPI_MakeSphere.hxx>
#include <BRep_Tool.hxx>
#include <GeomAdaptor_Curve.hxx>
#include <Geom_CylindricalSurface.hxx>
#include <Geom_Plane.hxx>
#include <ShapeFix_Edge.hxx>
#include <TopExp_Explorer.hxx>
#include <TopoDS.hxx>
#include <gp_Ax3.hxx>
#include <gp_Circ.hxx>

#include <cmath>
#include <cstdio>
#include <vector>

using namespace idealize;

namespace {

int failures = 0;

#define CHECK(condition)                                                          \
  do {                                                                            \
    if (!(condition)) {                                                           \
      std::fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #condition); \
      ++failures;                                                                 \
    }                                                                             \
  } while (0)

bool near(double a, double b, double tol = 1e-9) { return std::abs(a - b) <= tol; }

Surface plane(const Vec3& point, const Vec3& normal) {
  Surface s;
  s.type = SurfaceType::Plane;
  s.point = point;
  s.axis = normal.normalized();
  return s;
}

Surface cylinder(const Vec3& point, const Vec3& axis, double radius) {
  Surface s;
  s.type = SurfaceType::Cylinder;
  s.point = point;
  s.axis = axis.normalized();
  s.radius = radius;
  return s;
}

Surface sphere(const Vec3& centre, double radius) {
  Surface s;
  s.type = SurfaceType::Sphere;
  s.point = centre;
  s.radius = radius;
  return s;
}

// Largest distance from `a` and `b` of the curve, sampled at 33 points of [u0, u1].
double off_both(const Handle(Geom_Curve)& curve, double u0, double u1, const Surface& a, const Surface& b) {
  double worst = 0.0;
  for (int i = 0; i <= 32; ++i) {
    const Vec3 p = to_vec(curve->Value(u0 + (u1 - u0) * i / 32));
    worst = std::max({worst, std::abs(signed_distance(a, p)), std::abs(signed_distance(b, p))});
  }
  return worst;
}

void test_intersections_in_the_plane() {
  // Two lines cross in one point.
  auto hits = intersect(line2(Vec2(0, 1), Vec2(1, 0)), line2(Vec2(2, 0), Vec2(0, 1)), 1e-6, false);
  CHECK(hits.size() == 1 && (hits[0] - Vec2(2, 1)).norm() < 1e-12);
  // A line through a circle: two crossings; one that misses by less than tol touches it.
  hits = intersect(line2(Vec2(0, 0), Vec2(1, 0)), circle2(Vec2(0, 0), 2.0), 1e-6, false);
  CHECK(hits.size() == 2 && near(std::abs(hits[0].x()), 2.0) && near(std::abs(hits[1].x()), 2.0));
  hits = intersect(line2(Vec2(0, 2.0 + 5e-7), Vec2(1, 0)), circle2(Vec2(0, 0), 2.0), 1e-6, false);
  CHECK(hits.size() == 1 && near(hits[0].x(), 0.0, 1e-12));
  // Crossings inside the touching zone come with crossings_too, the contact last.
  hits = intersect(line2(Vec2(0, 2.0 - 5e-7), Vec2(1, 0)), circle2(Vec2(0, 0), 2.0), 1e-6, true);
  CHECK(hits.size() == 3 && near(hits[2].x(), 0.0, 1e-12));
  // Two circles.
  hits = intersect(circle2(Vec2(0, 0), 1.0), circle2(Vec2(1, 0), 1.0), 1e-9, false);
  CHECK(hits.size() == 2 && near(hits[0].x(), 0.5) && near(std::abs(hits[0].y()), std::sqrt(0.75)));
}

void test_closed_form_curves() {
  const double tol = 1e-6, eps = 1e-9;
  {  // two planes: their line
    const Surface a = plane(Vec3(0, 0, 0), Vec3(0, 0, 1)), b = plane(Vec3(1, 0, 0), Vec3(1, 0, 0));
    const std::vector<Vec3> chain = {Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(1, 2, 0)};
    const Handle(Geom_Curve) c = closed_form_curve(a, b, chain, {}, eps, tol);
    CHECK(!c.IsNull() && off_both(c, -5, 5, a, b) < 1e-12);
  }
  {  // a plane across a cylinder's axis: a circle of its radius
    const Surface a = cylinder(Vec3(0, 0, 0), Vec3(0, 0, 1), 2.0), b = plane(Vec3(0, 0, 1), Vec3(0, 0, 1));
    const std::vector<Vec3> chain = {Vec3(2, 0, 1), Vec3(0, 2, 1), Vec3(-2, 0, 1)};
    const Handle(Geom_Curve) c = closed_form_curve(a, b, chain, {}, eps, tol);
    CHECK(!c.IsNull() && GeomAdaptor_Curve(c).GetType() == GeomAbs_Circle);
    CHECK(!c.IsNull() && off_both(c, 0, 2 * M_PI, a, b) < 1e-12);
  }
  {  // a plane along a cylinder, touching it: the line of contact
    const Surface a = cylinder(Vec3(0, 0, 0), Vec3(0, 0, 1), 2.0), b = plane(Vec3(2, 0, 0), Vec3(1, 0, 0));
    const std::vector<Vec3> chain = {Vec3(2, 0, 0), Vec3(2, 0, 1), Vec3(2, 0, 2)};
    const Handle(Geom_Curve) c = closed_form_curve(a, b, chain, {}, eps, tol);
    CHECK(!c.IsNull() && GeomAdaptor_Curve(c).GetType() == GeomAbs_Line && off_both(c, -3, 3, a, b) < 1e-12);
  }
  {  // an oblique plane cuts a cylinder in an ellipse
    const Vec3 n(0, std::sin(0.5), std::cos(0.5));
    const Surface a = cylinder(Vec3(0, 0, 0), Vec3(0, 0, 1), 1.0), b = plane(Vec3(0, 0, 0), n);
    const std::vector<Vec3> chain = {Vec3(1, 0, 0), Vec3(-1, 0, 0)};
    const Handle(Geom_Curve) c = closed_form_curve(a, b, chain, {}, eps, tol);
    CHECK(!c.IsNull() && GeomAdaptor_Curve(c).GetType() == GeomAbs_Ellipse && off_both(c, 0, 2 * M_PI, a, b) < 1e-12);
  }
  {  // a plane through a sphere: the circle on the side of the chain
    const Surface a = sphere(Vec3(0, 0, 0), 3.0), b = plane(Vec3(0, 0, 1), Vec3(0, 0, 1));
    const std::vector<Vec3> chain = {Vec3(std::sqrt(8.0), 0, 1), Vec3(0, std::sqrt(8.0), 1)};
    const Handle(Geom_Curve) c = closed_form_curve(a, b, chain, {}, eps, tol);
    CHECK(!c.IsNull() && GeomAdaptor_Curve(c).GetType() == GeomAbs_Circle);
    CHECK(!c.IsNull() && near(GeomAdaptor_Curve(c).Circle().Radius(), std::sqrt(8.0)) && off_both(c, 0, 2 * M_PI, a, b) < 1e-12);
  }
  {  // planes that are parallel have no curve
    const Surface a = plane(Vec3(0, 0, 0), Vec3(0, 0, 1)), b = plane(Vec3(0, 0, 1), Vec3(0, 0, 1));
    CHECK(closed_form_curve(a, b, {Vec3(0, 0, 0)}, {}, eps, tol).IsNull());
  }
}

void test_curve_parameters_and_projection() {
  const Surface a = plane(Vec3(0, 0, 0), Vec3(0, 0, 1)), b = plane(Vec3(0, 0, 0), Vec3(0, 1, 0));
  const Handle(Geom_Curve) line = closed_form_curve(a, b, {Vec3(0, 0, 0), Vec3(1, 0, 0)}, {}, 1e-9, 1e-6);
  CHECK(!line.IsNull());
  if (line.IsNull()) return;
  // The parameter of a point off the line is that of its foot.
  const double u = curve_parameter(line, Vec3(2.5, 0.3, -0.2));
  CHECK((to_vec(line->Value(u)) - Vec3(2.5, 0, 0)).norm() < 1e-12);
  CHECK(near(max_distance_to_curve(line, {Vec3(1, 0.5, 0), Vec3(2, 0, 0)}), 0.5));
  // Points near the line move onto both planes.
  const LocalSurface la = [&](const Vec3&) { return a; }, lb = [&](const Vec3&) { return b; };
  for (const Vec3& p : project_on_both({Vec3(1, 0.01, 0.02), Vec3(2, -0.02, 0.01)}, la, &lb))
    CHECK(std::abs(p.y()) < 1e-12 && std::abs(p.z()) < 1e-12);
  // A B-spline through points of a circle stays within tol of it.
  std::vector<Vec3> arc;
  for (int i = 0; i <= 40; ++i) arc.emplace_back(std::cos(i * 0.05), std::sin(i * 0.05), 0.0);
  const Handle(Geom_Curve) fitted = fitted_curve(arc, 1e-4);
  CHECK(!fitted.IsNull());
  if (!fitted.IsNull()) {
    for (int i = 0; i <= 20; ++i) {
      const Vec3 p = to_vec(fitted->Value(fitted->FirstParameter() + (fitted->LastParameter() - fitted->FirstParameter()) * i / 20));
      CHECK(std::abs(p.norm() - 1.0) < 1e-4);
    }
  }
}

void test_corner_solves() {
  // Three planes meet in one point, wherever the solve starts. (The damping that keeps a point near
  // its start where surfaces leave a direction free, 1e-6, biases it by that share of the way.)
  const std::vector<Surface> planes = {plane(Vec3(1, 0, 0), Vec3(1, 0, 0)), plane(Vec3(0, 2, 0), Vec3(0, 1, 0)),
                                       plane(Vec3(0, 0, 3), Vec3(0, 0, 1))};
  std::vector<LocalSurface> local;
  for (const Surface& s : planes) local.push_back([s](const Vec3&) { return s; });
  CHECK((corner_point(local, Vec3(0, 0, 0), 1e-6) - Vec3(1, 2, 3)).norm() < 1e-5 * Vec3(1, 2, 3).norm());
  CHECK((corner_point(local, Vec3(-5, 7, 1), 1e-6) - Vec3(1, 2, 3)).norm() < 1e-5 * Vec3(6, 5, 2).norm());
  // Two planes leave a line free: the point on it nearest the start.
  local.pop_back();
  CHECK((corner_point(local, Vec3(0, 0, 0.7), 1e-6) - Vec3(1, 2, 0.7)).norm() < 1e-5 * Vec3(1, 2, 0).norm());
  // A plane, a cylinder and a plane across it: on all three.
  const Surface cyl = cylinder(Vec3(0, 0, 0), Vec3(0, 0, 1), 2.0);
  const std::vector<Surface> mixed = {cyl, plane(Vec3(0, 0, 1), Vec3(0, 0, 1)), plane(Vec3(0, 0, 0), Vec3(0, 1, 0))};
  std::vector<LocalSurface> local_mixed;
  for (const Surface& s : mixed) local_mixed.push_back([s](const Vec3&) { return s; });
  const Vec3 corner = corner_point(local_mixed, Vec3(1.9, 0.1, 1.1), 1e-6);
  for (const Surface& s : mixed) CHECK(std::abs(signed_distance(s, corner)) < 1e-5);
  CHECK(corner.x() > 0);  // the branch near the start
  // Where a line meets a surface: its crossings, or where it only touches, that point.
  const std::vector<double> crossings = line_meets([](double t) { return t * t - 1.0; }, -3, 3, 1e-6);
  CHECK(crossings.size() == 2 && near(std::abs(crossings[0]), 1.0, 1e-7) && near(std::abs(crossings[1]), 1.0, 1e-7));
  const std::vector<double> touch = line_meets([](double t) { return t * t + 1e-8; }, -3, 3, 1e-6);
  CHECK(touch.size() == 1 && std::abs(touch[0]) < 1e-3);
}

void test_pcurves_and_checks() {
  // A circle on a cylinder gets an exact pcurve: its curve on the face lies on its 3D curve.
  const Handle(Geom_CylindricalSurface) surface = new Geom_CylindricalSurface(gp_Ax3(gp::Origin(), gp::DZ()), 2.0);
  const TopoDS_Edge bottom = BRepBuilderAPI_MakeEdge(gp_Circ(gp_Ax2(gp::Origin(), gp::DZ()), 2.0));
  const TopoDS_Face face = BRepBuilderAPI_MakeFace(surface, 0.0, 2 * M_PI, 0.0, 1.0, 1e-7);
  ShapeFix_Edge add;
  add.FixAddPCurve(bottom, face, Standard_False, 1e-6);
  BRepLib_CheckCurveOnSurface check(bottom, face);
  check.Perform();
  CHECK(check.IsDone() && check.MaxDistance() < 1e-7);
  CHECK(sampled_pcurve_gap(bottom, face) == 0.0);  // (measured on B-spline edges only)
  // A box is valid, closed and a solid; one face of it is open.
  const TopoDS_Shape box = BRepPrimAPI_MakeBox(1.0, 2.0, 3.0).Shape();
  CHECK(is_valid(box) && !has_free_edges(box) && !has_vanishing_edge(box));
  CHECK(is_valid_with_facets(box, [](const TopoDS_Face&) { return false; }));
  CHECK(is_valid_with_facets(box, [](const TopoDS_Face&) { return true; }));
  TopExp_Explorer first(box, TopAbs_FACE);
  CHECK(has_free_edges(first.Current()) && std::string(occt_surface_name(TopoDS::Face(first.Current()))) == "plane");
  std::vector<std::string> faults = closed_shell_faults(box, 0.01, 1e-7);
  CHECK(faults.size() == 6 && no_faults(faults));
}

void test_faces_at_fault() {
  // Each face of a box passes; a fin on one of its edges makes three faces meet there, and those
  // three are to blame (facets included: the fin is taken for one).
  const TopoDS_Shape box = BRepPrimAPI_MakeBox(1.0, 1.0, 1.0).Shape();
  CHECK(faces_at_fault(box, [](const TopoDS_Face&) { return false; }).empty());
  TopExp_Explorer edges(box, TopAbs_EDGE);
  const TopoDS_Edge shared = TopoDS::Edge(edges.Current());
  TopoDS_Vertex a, b;
  TopExp::Vertices(shared, a, b);
  const gp_Pnt pa = BRep_Tool::Pnt(a), pb = BRep_Tool::Pnt(b);
  const gp_Pnt tip(0.5 * (pa.X() + pb.X()) - 1.0, 0.5 * (pa.Y() + pb.Y()) - 1.0, 0.5 * (pa.Z() + pb.Z()));
  const TopoDS_Vertex top = BRepBuilderAPI_MakeVertex(tip);
  const TopoDS_Wire wire = BRepBuilderAPI_MakeWire(shared, BRepBuilderAPI_MakeEdge(b, top), BRepBuilderAPI_MakeEdge(top, a));
  const TopoDS_Face fin = BRepBuilderAPI_MakeFace(wire, Standard_True);
  BRep_Builder builder;
  TopoDS_Shell shell;
  builder.MakeShell(shell);
  for (TopExp_Explorer f(box, TopAbs_FACE); f.More(); f.Next()) builder.Add(shell, f.Current());
  builder.Add(shell, fin);
  const std::vector<FaceFault> faults = faces_at_fault(shell, [&](const TopoDS_Face& face) { return face.IsSame(fin); });
  CHECK(faults.size() == 3);
  for (const FaceFault& fault : faults) CHECK(fault.reason.find("more than two faces") != std::string::npos);
}

void test_euler_characteristic() {
  // 2 - 2 genus: a box, a cylinder (seam, two discs) and a sphere (seam, two poles) have 2; a box
  // with a bore through it (a face of two wires at each end) has 0.
  CHECK(euler_characteristic(BRepPrimAPI_MakeBox(1.0, 2.0, 3.0).Shape()) == 2);
  CHECK(euler_characteristic(BRepPrimAPI_MakeCylinder(1.0, 2.0).Shape()) == 2);
  CHECK(euler_characteristic(BRepPrimAPI_MakeSphere(1.0).Shape()) == 2);
  const TopoDS_Shape block = BRepPrimAPI_MakeBox(4.0, 4.0, 2.0).Shape();
  const TopoDS_Shape bore = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(2.0, 2.0, -1.0), gp::DZ()), 1.0, 4.0).Shape();
  CHECK(euler_characteristic(BRepAlgoAPI_Cut(block, bore).Shape()) == 0);
}

void test_two_sided_distance() {
  // A unit cube's mesh against the box: 0 both ways; against a box 0.1 lower: its top, 0.1 apart
  // (the mesh's top corners off the box, the box's top face off the mesh).
  TriangleMesh cube;
  cube.V.resize(8, 3);
  for (int i = 0; i < 8; ++i) cube.V.row(i) << (i & 1), (i >> 1) & 1, (i >> 2) & 1;
  cube.F.resize(12, 3);
  cube.F << 0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5;
  CHECK(near(enclosed_volume(cube), 1.0));
  for (const double height : {1.0, 0.9}) {
    const TopoDS_Shape box = BRepPrimAPI_MakeBox(1.0, 1.0, height).Shape();
    std::vector<TopoDS_Face> faces;
    for (TopExp_Explorer e(box, TopAbs_FACE); e.More(); e.Next()) faces.push_back(TopoDS::Face(e.Current()));
    std::vector<int> all = {0, 1, 2, 3, 4, 5, 6, 7};
    const ShapeMeshDistance d = shape_mesh_distance(faces, cube, {}, all, 0.01);
    double face_max = 0.0;
    for (double x : d.face_to_mesh) face_max = std::max(face_max, x);
    CHECK(near(face_max, 1.0 - height, 1e-9));
    CHECK(near(d.vertex_to_shape.maxCoeff(), 1.0 - height, 1e-9));
  }
}

}  // namespace

int main() {
  test_intersections_in_the_plane();
  test_closed_form_curves();
  test_curve_parameters_and_projection();
  test_corner_solves();
  test_pcurves_and_checks();
  test_two_sided_distance();
  test_faces_at_fault();
  test_euler_characteristic();
  if (failures) std::fprintf(stderr, "%d check(s) failed\n", failures);
  else std::printf("brep geometry: all checks passed\n");
  return failures == 0 ? 0 : 1;
}
