// Edge curves along the chains between regions, and the mesh's own border where a region is degraded (builder.h).
#include "brep/builder.h"

namespace idealize {

// The edge of a chain that the seam of a winding face crosses (round_face), also made as two edges
// that meet on the seam, for the faces on both sides. Returns false if the seam misses it.
bool BrepBuilder::split_at_seam(int chain, const Handle(Geom_Curve)& curve, double u0, double u1,
                                const TopoDS_Vertex& v0, const TopoDS_Vertex& v1, double tolerance) {
  const auto splitting = seam_splits_.find(chain);
  if (splitting == seam_splits_.end()) return true;
  const Handle(Geom_Curve) seam = region_surfaces_[splitting->second]->UIso(0.0);
  GeomAPI_ExtremaCurveCurve crossing(new Geom_TrimmedCurve(curve, u0, u1), seam);
  if (crossing.NbExtrema() == 0 || crossing.LowerDistance() > 10 * tol_) return false;
  double t, unused;
  crossing.LowerDistanceParameters(t, unused);
  if (!(t > u0 && t < u1)) return false;
  BRep_Builder builder;
  TopoDS_Vertex middle;
  builder.MakeVertex(middle, curve->Value(t), std::max(tolerance, Precision::Confusion()));
  std::array<TopoDS_Edge, 2> parts;
  const std::array<std::array<double, 2>, 2> ranges = {{{u0, t}, {t, u1}}};
  const std::array<std::array<TopoDS_Vertex, 2>, 2> ends = {{{v0, middle}, {middle, v1}}};
  for (int i = 0; i < 2; ++i) {
    builder.MakeEdge(parts[i], curve, tolerance);
    builder.Add(parts[i], ends[i][0].Oriented(TopAbs_FORWARD));
    builder.Add(parts[i], ends[i][1].Oriented(TopAbs_REVERSED));
    builder.Range(parts[i], ranges[i][0], ranges[i][1]);
  }
  split_edges_[chain] = parts;
  return true;
}

// One chain's edge, computed from the surfaces and the mesh alone (chains are independent: on two
// threads): its curve, range, ends and tolerance, or why it has none.
BrepBuilder::ChainCurve BrepBuilder::chain_curve(size_t c) const {
  ChainCurve out;
  const BoundaryChain& chain = topo_.chains[c];
  BrepEdge& report = out.report;
  report.a = topo_.region_feature[chain.left];
  report.b = chain.right >= 0 ? topo_.region_feature[chain.right] : -1;
  report.mesh_vertices = static_cast<int>(chain.vertices.size());
  report.closed = chain.closed;
  // A freeform feature's side is its B-spline. One that has none leaves the edge to the surface
  // on the other side alone (as on an open boundary), so that the face there is still made.
  const auto unfitted = [&](int feature) {
    return feature >= 0 && surfaces_[feature].type == SurfaceType::Freeform && !freeform_.count(feature);
  };
  const bool a_unfitted = unfitted(report.a), b_unfitted = unfitted(report.b);
  if (a_unfitted && (report.b < 0 || b_unfitted)) return out;
  const int feature_a = a_unfitted ? report.b : report.a;
  const int feature_b = a_unfitted || b_unfitted ? -1 : report.b;
  const Surface& a = surfaces_[feature_a];
  const Surface* b = feature_b >= 0 ? &surfaces_[feature_b] : nullptr;
  const bool analytic = a.type != SurfaceType::Freeform && (!b || b->type != SurfaceType::Freeform);
  const LocalSurface local_a = local_surface(feature_a);
  const LocalSurface local_b = b ? local_surface(feature_b) : LocalSurface();
  std::vector<Vec3> raw;
  for (int v : chain.vertices) raw.push_back(mesh_.V.row(v).transpose());
  const std::vector<Vec3> points = project_on_both(raw, local_a, b ? &local_b : nullptr);
  // A point's distance from the farther of the edge's surfaces.
  const auto off = [&](const Vec3& p) {
    return std::max(std::abs(signed_distance(local_a(p), p)), b ? std::abs(signed_distance(local_b(p), p)) : 0.0);
  };
  try {
    // A closed form is the exact answer when the chain lies near it; surfaces that touch
    // tangentially leave the mesh boundary anywhere in the zone where they are close. Surfaces
    // that are parallel or coaxial only nearly (idealization left them: a sculpted part) get
    // the closed form of the exact configuration when it stays near the chain: a line or circle
    // a little off one surface is a sound edge (its tolerance says by how much), the general
    // intersection of nearly tangent surfaces is not.
    Handle(Geom_Curve) curve;
    // The corners that an open chain's edge joins choose its branch in the exact configuration;
    // in the near one, whose touching zone is five times as wide, they lie off every branch.
    std::vector<Vec3> ends;
    if (!chain.closed) ends = {corner_points_.at(chain.vertices.front()), corner_points_.at(chain.vertices.back())};
    for (const auto& [angle_eps, gap, exact] :
         {std::tuple{angle_eps_, tol_, true}, std::tuple{nearly_parallel_, 5 * tol_, false}}) {
      if (b && analytic && curve.IsNull())
        curve = closed_form_curve(a, *b, points, exact ? ends : std::vector<Vec3>(), angle_eps, gap, nearly_parallel_);
      if (curve && max_distance_to_curve(curve, points) >
                       (tangent_along(curve, a, *b, points, tangent_angle_) ? 0.05 * diagonal_ : 5 * tol_))
        curve.Nullify();
    }
    report.curve = curve.IsNull() ? "" : "closed form";
    if (curve.IsNull() && b) {
      GeomAPI_IntSS intersection(region_surfaces_[chain.left], region_surfaces_[chain.right], 1e-3 * tol_);
      double best = 5 * tol_;
      if (intersection.IsDone()) {
        for (int i = 1; i <= intersection.NbLines(); ++i) {
          const double distance = max_distance_to_curve(intersection.Line(i), points);
          if (distance < best) {
            best = distance;
            curve = intersection.Line(i);
            report.curve = "intersection";
          }
        }
      }
    }
    if (curve.IsNull()) {
      // Through the corners that lie on both surfaces (points of the curve they meet on).
      const auto on_both = [&](const Vec3& corner) { return b && off(corner) <= tol_; };
      curve = chain.closed ? fitted_curve(points, tol_)
                           : fitted_between(points, on_both(ends[0]) ? &ends[0] : nullptr,
                                            on_both(ends[1]) ? &ends[1] : nullptr, tol_, off);
      report.curve = "fitted";
    }
    if (curve.IsNull()) {
      report.curve.clear();
      out.problem = "an edge of the feature could not be made";
      return out;
    }

    // Ends: the corners, or one new point on a closed chain (its vertex is made with the edge).
    const bool loop = chain.vertices.front() == chain.vertices.back();
    Vec3 p0, p1;
    if (chain.closed) {
      GeomAPI_ProjectPointOnCurve start(to_pnt(points.front()), curve);
      p0 = start.NbPoints() ? to_vec(start.NearestPoint()) : points.front();
      // A closed edge starts where it crosses the seam of the periodic face beside it: a full
      // band (a cylinder between two circles) is then bounded by circle, seam, circle, seam,
      // which healing does not have to split with gap-filling degenerate edges. A cap about a
      // pole or apex puts its seam through the vertex wherever it is. (Between two periodic
      // faces, whose seams differ, the mesh decides.)
      auto periodic = [&](int region) {
        return region >= 0 && !region_surfaces_[region].IsNull() && region_surfaces_[region]->IsUPeriodic() &&
               !is_cap(static_cast<size_t>(region));
      };
      // So does a circle beside a face that winds round its axis (whose seam its neighbour took).
      const bool winds = (chain.left >= 0 && region_winds_[chain.left]) || (chain.right >= 0 && region_winds_[chain.right]);
      if (periodic(chain.left) != periodic(chain.right) || (winds && periodic(chain.left) && periodic(chain.right))) {
        const int region = chain.left >= 0 && region_winds_[chain.left] ? chain.left
                           : chain.right >= 0 && region_winds_[chain.right] ? chain.right
                           : periodic(chain.left) ? chain.left : chain.right;
        const Handle(Geom_Curve) seam = region_surfaces_[region]->UIso(0.0);
        GeomAPI_ExtremaCurveCurve crossing(curve, seam);
        if (crossing.NbExtrema() > 0 && crossing.LowerDistance() <= 10 * tol_) {
          gp_Pnt on_curve, on_seam;
          crossing.NearestPoints(on_curve, on_seam);
          p0 = to_vec(on_curve);
        }
      }
      // A closed curve that is not periodic (an intersection loop of two cylinders) runs from
      // its first point round to it: the vertex goes there, not where the chain starts.
      if (!curve->IsPeriodic()) p0 = to_vec(curve->Value(curve->FirstParameter()));
      p1 = p0;
    } else {
      p0 = corner_points_.at(chain.vertices.front());
      p1 = corner_points_.at(chain.vertices.back());
    }
    const Vec3 probe = points[loop ? std::max<size_t>(1, points.size() / 4) : points.size() / 2];
    double u0 = 0, u1 = 0;
    for (int attempt = 0; attempt < 2; ++attempt) {
      const auto parameter = [&](const Vec3& p) { return curve_parameter(curve, p); };
      bool reverse = false;
      if (curve->IsPeriodic()) {
        const double period = curve->Period();
        const auto wrap = [&](double u) { return u - period * std::floor(u / period); };
        u0 = parameter(p0);
        const double span = loop ? period : wrap(parameter(p1) - u0);
        // A loop runs the way its mesh vertices do (from its first one, wherever the edge starts).
        reverse = loop ? wrap(parameter(probe) - parameter(points.front())) > 0.5 * period
                       : wrap(parameter(probe) - u0) > span;
        u1 = u0 + (span > 0 ? span : period);
      } else if (loop) {
        u0 = curve->FirstParameter();
        u1 = curve->LastParameter();
      } else {
        u0 = parameter(p0);
        u1 = parameter(p1);
        reverse = u1 < u0;
      }
      if (!reverse) break;
      if (attempt == 1) throw Standard_Failure("the edge's direction is ambiguous");
      curve = curve->Reversed();
    }
    // A fitted curve passes through the chain's points, which lie on both surfaces, and strays
    // from them in between by up to its fitting tolerance: its edge's tolerance says by how much.
    double edge_tolerance = Precision::Confusion();
    if (report.curve == "fitted") edge_tolerance = std::max(edge_tolerance, 1.01 * farthest_off(curve, u0, u1, off));
    out.curve = curve;
    out.u0 = u0, out.u1 = u1, out.tolerance = edge_tolerance;
    out.p0 = p0, out.p1 = p1;
  } catch (const Standard_Failure& failure) {
    out.report.curve.clear();
    out.problem = occt_message(failure, "an edge could not be made");
  }
  return out;
}

void BrepBuilder::compute_curves() {
  const size_t chains = topo_.chains.size();
  curves_.assign(chains, ChainCurve());
  std::vector<std::exception_ptr> errors(chains);  // raised after the threads, as the first chain's would be
  on_two_threads_as_free(static_cast<int>(chains), [&](int c) {
    try {
      if (!collapsed_[c]) curves_[c] = chain_curve(c);
    } catch (...) {
      errors[c] = std::current_exception();
    }
  }, progress_);
  for (const std::exception_ptr& error : errors)
    if (error) std::rethrow_exception(error);
}

// The mesh's own border between two regions, where one of them is faceted or their curve failed:
// its vertices move onto the surfaces of the analytic regions beside it (onto both, where both are),
// so that the straight edges between them bound those faces within the tolerance their pcurves
// measure. Corners stay the vertices that the analytic edges end at.
void BrepBuilder::place_polylines() {
  facets_ = std::make_unique<FacetBuilder>(clean_);
  facet_region_.clear();
  facet_planes_.clear();
  const auto analytic = [&](int r) { return r >= 0 && !faceted_[r] && !region_surfaces_[r].IsNull(); };
  // A corner where an analytic face meets is the vertex its edges end at; among facets alone it
  // stays the mesh's vertex (the surfaces may have put two corners at one point).
  std::vector<char> touches_analytic(clean_.num_vertices(), 0);
  for (int f = 0; f < clean_.num_faces(); ++f)
    if (analytic(topo_.face_region[f]))
      for (int k = 0; k < 3; ++k) touches_analytic[clean_.F(f, k)] = 1;
  for (const auto& [v, vertex] : vertices_)
    if (touches_analytic[v]) facets_->share(v, vertex);
  // A chain whose corners the surfaces put at one point is that point for the facets beside it
  // too: its triangles there have no area, and its border no loop (which would cross itself).
  for (size_t c = 0; c < topo_.chains.size(); ++c) {
    const BoundaryChain& chain = topo_.chains[c];
    if (!collapsed_[c] || !(touches_analytic[chain.vertices.front()] || touches_analytic[chain.vertices.back()])) continue;
    if (!faceted_[chain.left] && (chain.right < 0 || !faceted_[chain.right])) continue;
    for (int v : chain.vertices) facets_->share(v, vertices_.at(chain.vertices.front()));
  }
  for (size_t c = 0; c < topo_.chains.size(); ++c) {
    progress_.check();
    if (!polyline_[c]) continue;
    const BoundaryChain& chain = topo_.chains[c];
    std::vector<LocalSurface> sides;
    for (int r : {chain.left, chain.right})
      if (analytic(r)) sides.push_back(local_surface(topo_.region_feature[r]));
    if (sides.empty()) continue;
    const size_t first = chain.closed ? 0 : 1, end = chain.closed ? chain.vertices.size() : chain.vertices.size() - 1;
    std::vector<Vec3> raw;
    for (size_t i = first; i < end; ++i) raw.push_back(clean_.V.row(chain.vertices[i]).transpose());
    const std::vector<Vec3> placed = project_on_both(raw, sides[0], sides.size() > 1 ? &sides[1] : nullptr);
    for (size_t i = first; i < end; ++i) facets_->place(chain.vertices[i], placed[i - first]);
  }
}

// The vertices of a polyline chain. Beside a facet, all of them (the facets use them). Between two
// analytic faces, those that advance along the chain once moved onto both surfaces, at least a
// tolerance apart: noisy border vertices projected onto the surfaces' intersection may step back
// along it, and the edge would cross itself.
std::vector<int> BrepBuilder::polyline_vertices(size_t c) const {
  const BoundaryChain& chain = topo_.chains[c];
  const bool facet_beside = faceted_[chain.left] || (chain.right >= 0 && faceted_[chain.right]);
  if (facet_beside || chain.vertices.size() < 3) return chain.vertices;
  std::vector<int> kept = {chain.vertices.front()};
  const size_t n = chain.vertices.size();
  const Vec3 end = facets_->position(chain.vertices.back());
  for (size_t i = 1; i + 1 < n; ++i) {
    const Vec3 last = facets_->position(kept.back()), p = facets_->position(chain.vertices[i]);
    const Vec3 along = chain.closed ? Vec3(clean_.V.row(chain.vertices[i + 1]) - clean_.V.row(chain.vertices[i - 1])).eval()
                                    : (end - last).eval();
    const bool advances = (p - last).dot(along) > 0.0 && (chain.closed || (end - p).norm() < (end - last).norm());
    if (advances && (p - last).norm() > tol_ && (chain.closed || (end - p).norm() > tol_)) kept.push_back(chain.vertices[i]);
  }
  kept.push_back(chain.vertices.back());
  return kept;
}

void BrepBuilder::make_edges(BrepResult& result) {
  BRep_Builder builder;
  const size_t chains = topo_.chains.size();
  edges_.assign(chains, TopoDS_Edge());
  edge_ok_.assign(chains, 0);
  split_edges_.clear();
  chain_pieces_.clear();
  const ProgressSpan progress = progress_.sub("edges", 0.55, 0.8);
  // The edges, their vertices' tolerances and the seam splits, in chain order.
  for (size_t c = 0; c < chains; ++c) {
    progress.step(static_cast<double>(c) / chains);
    const BoundaryChain& chain = topo_.chains[c];
    const ChainCurve& edge_curve = curves_[c];
    if (polyline_[c]) {
      std::vector<TopoDS_Edge>& pieces = chain_pieces_[c];
      const std::vector<int> kept = polyline_vertices(c);
      for (size_t i = 0; i + 1 < kept.size(); ++i)
        for (const TopoDS_Edge& piece : facets_->path(kept[i], kept[i + 1])) pieces.push_back(piece);
      edge_ok_[c] = 1;
      BrepEdge report = edge_curve.report;
      report.a = topo_.region_feature[chain.left];
      report.b = chain.right >= 0 ? topo_.region_feature[chain.right] : -1;
      report.mesh_vertices = static_cast<int>(chain.vertices.size());
      report.closed = chain.closed;
      report.curve = "polyline";
      result.edges.push_back(report);
      continue;
    }
    if (collapsed_[c]) {
      edge_ok_[c] = 1;
      continue;
    }
    result.edges.push_back(edge_curve.report);
    if (!edge_curve.problem.empty()) result.problems.push_back({topo_.region_feature[chain.left], edge_curve.problem});
    if (edge_curve.curve.IsNull()) continue;
    try {
      const Handle(Geom_Curve)& curve = edge_curve.curve;
      const double u0 = edge_curve.u0, u1 = edge_curve.u1;
      const Vec3 &p0 = edge_curve.p0, &p1 = edge_curve.p1;
      TopoDS_Vertex v0, v1;
      if (chain.closed) {
        builder.MakeVertex(v0, to_pnt(p0), Precision::Confusion());
        v1 = v0;
      } else {
        v0 = vertex_at_corner(chain.vertices.front());
        v1 = vertex_at_corner(chain.vertices.back());
      }
      TopoDS_Edge edge;
      builder.MakeEdge(edge, curve, edge_curve.tolerance);
      builder.Add(edge, v0.Oriented(TopAbs_FORWARD));
      builder.Add(edge, v1.Oriented(TopAbs_REVERSED));
      builder.Range(edge, u0, u1);
      // Vertex tolerance: the gap between the corner point and the curve's end.
      builder.UpdateVertex(v0, std::max(BRep_Tool::Tolerance(v0), 1.01 * (to_vec(curve->Value(u0)) - p0).norm()));
      builder.UpdateVertex(v1, std::max(BRep_Tool::Tolerance(v1), 1.01 * (to_vec(curve->Value(u1)) - p1).norm()));
      edges_[c] = edge;
      edge_ok_[c] = split_at_seam(c, curve, u0, u1, v0, v1, edge_curve.tolerance);
    } catch (const Standard_Failure& failure) {
      result.edges.back().curve.clear();
      result.problems.push_back({topo_.region_feature[chain.left], occt_message(failure, "an edge could not be made")});
    }
  }
}

}  // namespace idealize
