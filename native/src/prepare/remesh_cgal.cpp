// CGAL-backed mesh surgery: isotropic remeshing and closest-face queries (see remesh_cgal.h).
//
// Everything CGAL stays inside this translation unit; the interface speaks TriangleMesh only.
#include "prepare/remesh_cgal.h"

#include "core/parallel.h"

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/box_intersection_d.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

namespace idealize {

namespace {

namespace PMP = CGAL::Polygon_mesh_processing;

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using Polygon = std::array<std::size_t, 3>;

// A remeshed surface larger than this is almost certainly a unit mistake (edge length given in
// metres for a part in millimetres); refuse it instead of exhausting memory.
constexpr double kMaxRemeshedTriangles = 5.0e7;

// Common checks on a user mesh: sizes, index range and finite coordinates.
void check_indexed_mesh(const TriangleMesh& mesh, const char* what) {
  const Eigen::Index nv = mesh.V.rows();
  const Eigen::Index nf = mesh.F.rows();
  if (nf == 0 || nv == 0) {
    std::ostringstream msg;
    msg << what << ": the mesh has no triangles";
    throw MeshError(msg.str());
  }
  for (Eigen::Index v = 0; v < nv; ++v)
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(mesh.V(v, c))) {
        std::ostringstream msg;
        msg << what << ": vertex " << v << " has a NaN or infinite coordinate";
        throw MeshError(msg.str());
      }
  for (Eigen::Index f = 0; f < nf; ++f)
    for (int c = 0; c < 3; ++c) {
      const int i = mesh.F(f, c);
      if (i < 0 || i >= nv) {
        std::ostringstream msg;
        msg << what << ": triangle " << f << " refers to vertex " << i << ", but the mesh has "
            << nv << " vertices";
        throw MeshError(msg.str());
      }
    }
}

// Builds a CGAL Surface_mesh from an indexed triangle mesh that must describe a manifold
// surface. A consistently oriented manifold soup is converted as is (keeping orientation and
// face order); a manifold soup with inconsistent orientation is re-oriented first. Anything
// CGAL would have to cut apart (edges shared by more than two triangles, pinched vertices) is
// refused with a MeshError naming the problem.
SurfaceMesh to_surface_mesh(const TriangleMesh& mesh, const char* what) {
  const Eigen::Index nv = mesh.V.rows();
  const Eigen::Index nf = mesh.F.rows();

  std::vector<Point> points;
  points.reserve(static_cast<std::size_t>(nv));
  for (Eigen::Index v = 0; v < nv; ++v) points.emplace_back(mesh.V(v, 0), mesh.V(v, 1), mesh.V(v, 2));

  std::vector<Polygon> polygons;
  polygons.reserve(static_cast<std::size_t>(nf));
  long long repeated_vertex = 0;
  for (Eigen::Index f = 0; f < nf; ++f) {
    const Polygon p{static_cast<std::size_t>(mesh.F(f, 0)), static_cast<std::size_t>(mesh.F(f, 1)),
                    static_cast<std::size_t>(mesh.F(f, 2))};
    if (p[0] == p[1] || p[1] == p[2] || p[2] == p[0]) {
      ++repeated_vertex;
      continue;
    }
    polygons.push_back(p);
  }
  if (repeated_vertex > 0) {
    std::ostringstream msg;
    msg << what << ": " << repeated_vertex
        << " triangle(s) use the same vertex twice (collapsed triangles); repair the mesh first";
    throw MeshError(msg.str());
  }

  if (!PMP::is_polygon_soup_a_polygon_mesh(polygons)) {
    // Count edges used by more than two triangles, to say what is wrong in words.
    std::vector<std::pair<std::size_t, std::size_t>> edges;
    edges.reserve(3 * polygons.size());
    for (const Polygon& p : polygons)
      for (int c = 0; c < 3; ++c) {
        std::size_t a = p[c], b = p[(c + 1) % 3];
        if (a > b) std::swap(a, b);
        edges.emplace_back(a, b);
      }
    std::sort(edges.begin(), edges.end());
    long long nonmanifold_edges = 0;
    for (std::size_t i = 0; i < edges.size();) {
      std::size_t j = i;
      while (j < edges.size() && edges[j] == edges[i]) ++j;
      if (j - i > 2) ++nonmanifold_edges;
      i = j;
    }
    if (nonmanifold_edges > 0) {
      std::ostringstream msg;
      msg << what << ": the mesh is not manifold (" << nonmanifold_edges
          << " edge(s) shared by more than two triangles); repair the mesh first";
      throw MeshError(msg.str());
    }
    // Only orientation or pinched vertices can be wrong now. Re-orienting succeeds without
    // duplicating points exactly when the surface is a manifold that was merely mis-oriented.
    if (!PMP::orient_polygon_soup(points, polygons)) {
      std::ostringstream msg;
      msg << what
          << ": the mesh is not manifold (vertices where separate sheets touch, or a "
             "non-orientable surface); repair the mesh first";
      throw MeshError(msg.str());
    }
    if (!PMP::is_polygon_soup_a_polygon_mesh(polygons)) {
      std::ostringstream msg;
      msg << what << ": the triangles do not form a manifold surface; repair the mesh first";
      throw MeshError(msg.str());
    }
  }

  SurfaceMesh sm;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, sm);
  if (sm.number_of_faces() != polygons.size()) {
    std::ostringstream msg;
    msg << what << ": CGAL could not build a surface from the triangles";
    throw MeshError(msg.str());
  }
  return sm;
}

// Copies a (possibly garbage-carrying) Surface_mesh into a compact TriangleMesh.
TriangleMesh from_surface_mesh(const SurfaceMesh& sm) {
  TriangleMesh out;
  std::vector<int> index(sm.num_vertices() + sm.number_of_removed_vertices(), -1);
  out.V.resize(static_cast<Eigen::Index>(sm.number_of_vertices()), 3);
  int next = 0;
  for (SurfaceMesh::Vertex_index v : sm.vertices()) {
    const Point& p = sm.point(v);
    out.V(next, 0) = p.x();
    out.V(next, 1) = p.y();
    out.V(next, 2) = p.z();
    index[static_cast<std::size_t>(v)] = next++;
  }
  out.F.resize(static_cast<Eigen::Index>(sm.number_of_faces()), 3);
  int f = 0;
  for (SurfaceMesh::Face_index face : sm.faces()) {
    int c = 0;
    for (SurfaceMesh::Vertex_index v : CGAL::vertices_around_face(sm.halfedge(face), sm)) {
      if (c >= 3) throw MeshError("isotropic remeshing produced a non-triangular face");
      out.F(f, c++) = index[static_cast<std::size_t>(v)];
    }
    if (c != 3) throw MeshError("isotropic remeshing produced a non-triangular face");
    ++f;
  }
  return out;
}

bool is_degenerate(const Point& a, const Point& b, const Point& c) {
  return CGAL::collinear(a, b, c);
}

}  // namespace

TriangleMesh remesh_isotropic(const TriangleMesh& mesh, double target_edge_length, int iterations) {
  if (!std::isfinite(target_edge_length) || !(target_edge_length > 0.0)) {
    std::ostringstream msg;
    msg << "isotropic remeshing: the target edge length must be a positive finite number, got "
        << target_edge_length;
    throw std::invalid_argument(msg.str());
  }
  if (iterations < 1) {
    std::ostringstream msg;
    msg << "isotropic remeshing: the number of iterations must be at least 1, got " << iterations;
    throw std::invalid_argument(msg.str());
  }
  check_indexed_mesh(mesh, "isotropic remeshing");

  SurfaceMesh sm = to_surface_mesh(mesh, "isotropic remeshing");

  // Refuse absurd requests before CGAL tries to allocate them: an equilateral triangle of side L
  // has area sqrt(3)/4 L^2.
  const double area = PMP::area(sm);
  const double expected = area / (std::sqrt(3.0) / 4.0 * target_edge_length * target_edge_length);
  if (expected > kMaxRemeshedTriangles) {
    std::ostringstream msg;
    msg << "isotropic remeshing: target edge length " << target_edge_length
        << " is too small for a surface of area " << area << " (about " << expected
        << " triangles); use a larger edge length";
    throw MeshError(msg.str());
  }

  try {
    // No edge is constrained: sharp edges are resampled like a scanner samples them.
    PMP::isotropic_remeshing(faces(sm), target_edge_length, sm,
                             CGAL::parameters::number_of_iterations(static_cast<unsigned int>(iterations))
                                 .protect_constraints(false)
                                 .do_project(true));
  } catch (const MeshError&) {
    throw;
  } catch (const std::exception& e) {
    throw MeshError(std::string("isotropic remeshing failed: ") + e.what());
  }

  if (sm.number_of_faces() == 0) throw MeshError("isotropic remeshing removed every triangle");
  return from_surface_mesh(sm);
}

namespace {

// Stops the box intersection once enough pairs are counted.
struct EnoughPairs {};

}  // namespace

long long count_self_intersections(const TriangleMesh& mesh, long long max_pairs, const ProgressSpan& progress) {
  // Single-precision boxes rounded outwards (conservative, half the memory of doubles) carrying
  // their triangle's corners, stored by value: measured 1.6 times faster than PMP's double boxes
  // behind pointers on a million triangles.
  struct Corners {
    int v[3];
  };
  using Box = CGAL::Box_intersection_d::Box_with_info_d<float, 3, Corners, CGAL::Box_intersection_d::ID_EXPLICIT>;
  const int nf = mesh.num_faces();
  if (max_pairs <= 0 || nf < 2) return 0;
  std::vector<Point> points;
  points.reserve(static_cast<std::size_t>(mesh.num_vertices()));
  for (int v = 0; v < mesh.num_vertices(); ++v) points.emplace_back(mesh.V(v, 0), mesh.V(v, 1), mesh.V(v, 2));
  std::vector<Box> boxes;
  boxes.reserve(static_cast<std::size_t>(nf));
  const ProgressSpan indexing = progress.sub(0.0, 0.1);
  for (int f = 0; f < nf; ++f) {
    indexing.tick(f, nf);
    const Corners t{{mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2)}};
    const Point &p = points[t.v[0]], &q = points[t.v[1]], &r = points[t.v[2]];
    if (CGAL::collinear(p, q, r)) continue;
    float low[3], high[3];
    for (int k = 0; k < 3; ++k) {
      const double lo = std::min({p[k], q[k], r[k]}), hi = std::max({p[k], q[k], r[k]});
      low[k] = static_cast<float>(lo);
      high[k] = static_cast<float>(hi);
      if (static_cast<double>(low[k]) > lo) low[k] = std::nextafter(low[k], -std::numeric_limits<float>::infinity());
      if (static_cast<double>(high[k]) < hi) high[k] = std::nextafter(high[k], std::numeric_limits<float>::infinity());
    }
    boxes.emplace_back(low, high, t);
  }
  progress.step(0.1);

  const auto intersect = [&](const Corners& ft, const Corners& gt) {
    const int* fv = ft.v;
    const int* gv = gt.v;
    int shared = 0, fi = -1, gi = -1;  // with one shared vertex: its corners in f and g
    bool f_shared[3] = {false, false, false}, g_shared[3] = {false, false, false};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (fv[i] == gv[j]) {
          ++shared;
          f_shared[i] = g_shared[j] = true;
          fi = i, gi = j;
        }
    if (shared >= 3) return false;  // prepare_mesh merged duplicates; nothing to report
    if (shared == 2) {
      // Along a shared edge: only coplanar triangles folded onto each other overlap.
      int f_own = 0, g_own = 0;  // the corners not shared
      for (int i = 0; i < 3; ++i) {
        if (!f_shared[i]) f_own = i;
        if (!g_shared[i]) g_own = i;
      }
      const Point& a = points[fv[(f_own + 1) % 3]];
      const Point& b = points[fv[(f_own + 2) % 3]];
      const Point& p = points[fv[f_own]];
      const Point& q = points[gv[g_own]];
      return CGAL::coplanar(a, b, p, q) && CGAL::coplanar_orientation(a, b, p, q) == CGAL::POSITIVE;
    }
    if (shared == 1) {
      // At a shared vertex: the opposite side of one crosses the other triangle. Cheap exit first:
      // each opposite side lies strictly on one side of the other triangle's plane.
      const Point& v = points[fv[fi]];
      const Point &a1 = points[fv[(fi + 1) % 3]], &b1 = points[fv[(fi + 2) % 3]];
      const Point &a2 = points[gv[(gi + 1) % 3]], &b2 = points[gv[(gi + 2) % 3]];
      const CGAL::Orientation oa2 = CGAL::orientation(v, a1, b1, a2);
      if (oa2 != CGAL::COPLANAR && oa2 == CGAL::orientation(v, a1, b1, b2)) {
        const CGAL::Orientation oa1 = CGAL::orientation(v, a2, b2, a1);
        if (oa1 != CGAL::COPLANAR && oa1 == CGAL::orientation(v, a2, b2, b1)) return false;
      }
      const Kernel::Triangle_3 tf(v, a1, b1), tg(v, a2, b2);
      return CGAL::do_intersect(tf, Kernel::Segment_3(a2, b2)) || CGAL::do_intersect(tg, Kernel::Segment_3(a1, b1));
    }
    return CGAL::do_intersect(Kernel::Triangle_3(points[fv[0]], points[fv[1]], points[fv[2]]),
                              Kernel::Triangle_3(points[gv[0]], points[gv[1]], points[gv[2]]));
  };

  long long pairs = 0, candidates = 0;
  const auto callback = [&](const Box& a, const Box& b) {
    progress.poll(++candidates, 1 << 14);
    if (!intersect(a.info(), b.info())) return;
    if (++pairs >= max_pairs) throw EnoughPairs();
  };
  try {
    // A larger cutoff than PMP's 2000 (brute force below it) measured faster on scans.
    CGAL::box_self_intersection_d<CGAL::Sequential_tag>(boxes.begin(), boxes.end(), callback, std::ptrdiff_t(10000));
  } catch (const EnoughPairs&) {
  }
  progress.step(1.0);
  return pairs;
}

std::vector<int> closest_faces(const TriangleMesh& mesh, const MatrixX3d& points, std::vector<double>* distances,
                               const ProgressSpan& progress) {
  check_indexed_mesh(mesh, "closest faces");
  for (Eigen::Index i = 0; i < points.rows(); ++i)
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(points(i, c))) {
        std::ostringstream msg;
        msg << "closest faces: query point " << i << " has a NaN or infinite coordinate";
        throw std::invalid_argument(msg.str());
      }

  // Every input triangle becomes its own component with three private vertices, so any triangle
  // set (non-manifold, inconsistently oriented) is a valid face graph and each face keeps a known
  // input index. Triangles with collinear corners are left out: their points lie on the edges of
  // their neighbours, and CGAL's closest-point construction is not defined on them.
  SurfaceMesh sm;
  const Eigen::Index nf = mesh.F.rows();
  std::vector<int> face_row;
  face_row.reserve(static_cast<std::size_t>(nf));
  sm.reserve(static_cast<SurfaceMesh::size_type>(3 * nf), static_cast<SurfaceMesh::size_type>(3 * nf),
             static_cast<SurfaceMesh::size_type>(nf));
  const ProgressSpan indexing = progress.sub(0.0, 0.1);
  for (Eigen::Index f = 0; f < nf; ++f) {
    indexing.tick(f, nf);
    std::array<Point, 3> p;
    for (int c = 0; c < 3; ++c) {
      const int v = mesh.F(f, c);
      p[c] = Point(mesh.V(v, 0), mesh.V(v, 1), mesh.V(v, 2));
    }
    if (is_degenerate(p[0], p[1], p[2])) continue;
    const auto a = sm.add_vertex(p[0]), b = sm.add_vertex(p[1]), c = sm.add_vertex(p[2]);
    const auto face = sm.add_face(a, b, c);
    if (face == SurfaceMesh::null_face()) throw MeshError("closest faces: could not index a triangle");
    face_row.push_back(static_cast<int>(f));
  }
  if (face_row.empty())
    throw MeshError("closest faces: every triangle of the mesh is degenerate (zero area)");

  using Primitive = CGAL::AABB_face_graph_triangle_primitive<SurfaceMesh>;
  using Traits = CGAL::AABB_traits<Kernel, Primitive>;
  using Tree = CGAL::AABB_tree<Traits>;
  Tree tree(faces(sm).first, faces(sm).second, sm);
  tree.accelerate_distance_queries();
  progress.step(0.2);

  std::vector<int> result(static_cast<std::size_t>(points.rows()));
  if (distances) distances->resize(result.size());
  auto query = [&](int i) {
    const Point q(points(i, 0), points(i, 1), points(i, 2));
    const auto hit = tree.closest_point_and_primitive(q);
    result[static_cast<std::size_t>(i)] = face_row[static_cast<std::size_t>(hit.second)];
    if (distances) (*distances)[static_cast<std::size_t>(i)] = std::sqrt(CGAL::squared_distance(q, hit.first));
  };
  // The first query builds the tree's search structures (lazily, in CGAL); the others only read them.
  const int count = static_cast<int>(points.rows());
  if (count > 0) query(0);
  for_each_polled_on_two_threads(count - 1, progress.sub(0.2, 1.0), [&](int i) { query(i + 1); }, 1 << 12);
  progress.step(1.0);
  return result;
}

}  // namespace idealize
