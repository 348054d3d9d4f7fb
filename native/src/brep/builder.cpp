// The rounds of the B-rep construction, and build_brep (builder.h).
#include "brep/builder.h"

namespace idealize {
namespace {

// Each side of each triangle, as smaller vertex * #V + larger vertex, sorted (a side shared by two
// triangles twice).
std::vector<std::int64_t> sorted_edges(const TriangleMesh& mesh) {
  std::vector<std::int64_t> edges;
  edges.reserve(3 * static_cast<size_t>(mesh.num_faces()));
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int64_t a = mesh.F(f, k), b = mesh.F(f, (k + 1) % 3);
      edges.push_back(std::min(a, b) * mesh.num_vertices() + std::max(a, b));
    }
  std::sort(edges.begin(), edges.end());
  return edges;
}

// The edges of the facets, from sorted_edges: an edge of 2k triangles, k sheets touching, is k
// edges of the facets (one per pair).
long long facet_edge_count(const std::vector<std::int64_t>& edges) {
  long long edge_count = 0;
  for (size_t i = 0, j = 0; i < edges.size(); i = j) {
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    edge_count += static_cast<long long>(j - i + 1) / 2;
  }
  return edge_count;
}

}  // namespace

std::vector<int> BrepBuilder::merge_same_surfaces(const std::vector<int>& labels) const {
  std::vector<int> representative(surfaces_.size());
  for (size_t i = 0; i < surfaces_.size(); ++i) {
    representative[i] = static_cast<int>(i);
    for (size_t j = 0; j < i; ++j) {
      if (representative[j] == static_cast<int>(j) && same_surface(surfaces_[i], surfaces_[j], 1e-6 * diagonal_)) {
        representative[i] = static_cast<int>(j);
        break;
      }
    }
  }
  std::vector<int> merged(labels.size());
  for (size_t f = 0; f < labels.size(); ++f) merged[f] = labels[f] < 0 ? -1 : representative[labels[f]];
  return merged;
}

// A scanner samples a sharp edge as a rounded strip about one sample spacing wide, which fits a
// cylinder (or torus, sphere at corners) of about that radius: on a sampled (not exactly
// tessellated) mesh, round features with a radius below two median edge lengths that are less
// than one and a half wide (twice their area over their border's length) are such strips, and their
// triangles go back to the features on either side (the thesis folds transition strips into the
// neighbouring patches). A fillet of such a radius across several facets stays (a scanned
// hexagon nut: r 1 on edges of 0.6, two edges wide). An exact CAD tessellation keeps every feature.
// For a layer stored without its mesh kind: an exact tessellation is one where half or more of the
// features fit exactly (a CAD export's vertices may lie on a B-spline approximation of its tori, a
// few thousandths of the tolerance off the ideal surface; or be rounded to single precision far
// from the origin).
bool BrepBuilder::most_features_exact(const TriangleMesh& mesh, const std::vector<int>& labels) const {
  const int features = static_cast<int>(surfaces_.size());
  std::vector<double> squared(features, 0.0), count(features, 0.0);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (labels[f] < 0 || surfaces_[labels[f]].type == SurfaceType::Freeform) continue;
    for (int c = 0; c < 3; ++c) {
      const double d = signed_distance(surfaces_[labels[f]], mesh.V.row(mesh.F(f, c)).transpose());
      squared[labels[f]] += d * d;
      count[labels[f]] += 1;
    }
  }
  const double exact_rms = std::max(kExactFraction * tol_, 2.0 * coordinate_floor(mesh));
  int exact = 0, fitted = 0;
  for (int i = 0; i < features; ++i) {
    if (count[i] == 0) continue;
    ++fitted;
    exact += std::sqrt(squared[i] / count[i]) < exact_rms;
  }
  return 2 * exact >= fitted;
}

std::vector<int> BrepBuilder::dissolve_sampling_blends(const TriangleMesh& mesh, const MeshTopology& topology,
                                                       std::vector<int> labels) const {
  const int features = static_cast<int>(surfaces_.size());
  std::vector<double> edges, shortest(mesh.num_faces());
  for (int f = 0; f < mesh.num_faces(); ++f) {
    shortest[f] = std::numeric_limits<double>::infinity();
    for (int c = 0; c < 3; ++c) {
      edges.push_back((mesh.V.row(mesh.F(f, c)) - mesh.V.row(mesh.F(f, (c + 1) % 3))).norm());
      shortest[f] = std::min(shortest[f], edges.back());
    }
  }
  if (edges.empty()) return labels;
  // An exact tessellation keeps every feature, as the feature layer decided it.
  if (mesh_kind_ ? *mesh_kind_ == MeshKind::ExactTessellation : most_features_exact(mesh, labels)) return labels;
  std::nth_element(edges.begin(), edges.begin() + edges.size() / 2, edges.end());
  const double spacing = edges[edges.size() / 2];
  // A scanner samples about evenly in every direction (the benchmark's scans: a typical facet's
  // shortest edge is 0.85-0.95 of the median edge); facets many times longer than wide are a CAD export's,
  // noisy or not, whose rounds span facets however narrow (a plate's corner radii and hole of 5
  // and 8 on sides of 20, tessellated in slivers 0.4 wide, took the strips' rule and vanished).
  std::nth_element(shortest.begin(), shortest.begin() + shortest.size() / 2, shortest.end());
  if (shortest[shortest.size() / 2] < 0.25 * spacing) return labels;
  // Each feature's width: twice its area over the length of its border.
  std::vector<double> area(features, 0.0), border(features, 0.0);
  const Eigen::VectorXd face_area = face_areas(mesh);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (labels[f] < 0) continue;
    area[labels[f]] += face_area[f];
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g < 0 || labels[g] != labels[f])
        border[labels[f]] += (mesh.V.row(mesh.F(f, c)) - mesh.V.row(mesh.F(f, (c + 1) % 3))).norm();
    }
  }
  std::vector<char> strip(features, 0);
  for (int i = 0; i < features; ++i) {
    const Surface& s = surfaces_[i];
    const double radius = s.type == SurfaceType::Torus ? s.minor : s.radius;
    const bool narrow = border[i] > 0.0 && 2.0 * area[i] / border[i] < 1.5 * spacing;
    strip[i] = (s.type == SurfaceType::Cylinder || s.type == SurfaceType::Torus || s.type == SurfaceType::Sphere) &&
               radius < 2 * spacing && narrow;
  }
  for (int& l : labels) {
    if (l >= 0 && strip[l]) l = -1;
  }
  return labels;
}

// Topology cleaning before any geometry (thesis 4.3.3): a region that a neighbouring region's
// analytic surface explains as well as its own cannot be told from that neighbour, and joins it
// (the one whose surface passes closest). Explained: its vertices lie on the neighbour's surface
// within the mesh's noise (on an exact tessellation, within what the layer calls exact), and the
// middles of its triangles within the tolerance or the neighbour's own sagitta. A one-triangle
// plane on a cylinder's facets, or a flat narrower than the tolerance between two tangent
// cylinders, joins; a step 0.03 high beside a plane, whose vertices lie 0.03 off it, stays, and
// so does a disc whose vertices all lie on its rim (where the blend beside it passes). Such a
// region's face could not be made anyway: its borders' corners are put at one point, and both
// borders become the same edge. Smallest regions first; a region that took another in is not
// given away itself. Returns the features with the joined regions' triangles relabelled (and
// lists the layer's features that joined in result.joined).
std::vector<int> BrepBuilder::join_explained_regions(std::vector<int> face_feature, BrepResult& result) const {
  const int regions = static_cast<int>(topo_.region_feature.size());
  const auto analytic = [&](int r) { return surfaces_[topo_.region_feature[r]].type != SurfaceType::Freeform; };
  const auto distance = [&](int r, const Vec3& p) { return std::abs(signed_distance(surfaces_[topo_.region_feature[r]], p)); };
  std::vector<std::vector<int>> vertices(regions), neighbours(regions);
  std::vector<double> sagitta(regions, 0.0), residuals;
  for (int r = 0; r < regions; ++r) {
    for (int f : region_faces_[r])
      for (int k = 0; k < 3; ++k) vertices[r].push_back(clean_.F(f, k));
    std::sort(vertices[r].begin(), vertices[r].end());
    vertices[r].erase(std::unique(vertices[r].begin(), vertices[r].end()), vertices[r].end());
    if (!analytic(r)) continue;
    for (int v : vertices[r]) residuals.push_back(distance(r, clean_.V.row(v).transpose()));
    for (int f : region_faces_[r]) {  // how far its triangles' middles lie off it beyond their corners
      double corners = 0.0;
      for (int k = 0; k < 3; ++k) corners += distance(r, clean_.V.row(clean_.F(f, k)).transpose()) / 3.0;
      sagitta[r] = std::max(sagitta[r], distance(r, face_centroid(clean_, f)) - corners);
    }
  }
  if (residuals.empty()) return face_feature;
  // The noise (noise_sigma, over the vertices of the regions with an analytic surface, before any
  // joins; measure_fits takes those of every region with a surface, after them; the largest of n
  // residuals is about sigma sqrt(2 ln n)), and what the layer calls an exact fit.
  const double sigma = noise_sigma(std::move(residuals));
  const double exact = std::max(kExactFraction * tol_, 2.0 * coordinate_floor(clean_));
  for (const BoundaryChain& chain : topo_.chains) {
    if (chain.right < 0) continue;
    neighbours[chain.left].push_back(chain.right);
    neighbours[chain.right].push_back(chain.left);
  }
  std::vector<int> order(regions);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return region_faces_[a].size() < region_faces_[b].size(); });
  std::vector<int> joined(regions, -1);
  std::vector<char> took(regions, 0);
  for (int r : order) {
    progress_.check();
    if (took[r]) continue;
    const double n = static_cast<double>(vertices[r].size());
    const double on = std::max(exact, n > 1 ? sigma * std::sqrt(2.0 * std::log(n)) : 0.0);
    std::sort(neighbours[r].begin(), neighbours[r].end());
    neighbours[r].erase(std::unique(neighbours[r].begin(), neighbours[r].end()), neighbours[r].end());
    int best = -1;
    double closest = std::numeric_limits<double>::infinity();
    for (int m : neighbours[r]) {
      if (joined[m] >= 0 || topo_.region_feature[m] == topo_.region_feature[r] || !analytic(m)) continue;
      double farthest = 0.0;
      bool explained = true;
      for (int v : vertices[r]) {
        farthest = std::max(farthest, distance(m, clean_.V.row(v).transpose()));
        if (!(explained = farthest <= on)) break;
      }
      const double middle = std::max(tol_, sagitta[m]);
      for (size_t i = 0; explained && i < region_faces_[r].size(); ++i)
        explained = distance(m, face_centroid(clean_, region_faces_[r][i])) <= middle;
      if (explained && farthest < closest) {
        closest = farthest;
        best = m;
      }
    }
    if (best < 0) continue;
    joined[r] = best;
    took[best] = 1;
    const int from = topo_.region_feature[r], to = topo_.region_feature[best];
    for (int f : region_faces_[r]) face_feature[f] = to;
    if (from < features_ && to < features_) result.joined.emplace_back(from, to);
  }
  return face_feature;
}

// The B-spline of each freeform feature, fitted to the vertices of its faces (weighted by a third of
// each face's area) with the face normals checking that it is a height field.
void BrepBuilder::fit_freeform_surfaces(const TriangleMesh& mesh, const std::vector<int>& face_feature,
                                        BrepResult& result) {
  std::map<int, std::vector<int>> faces;
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (face_feature[f] >= 0 && surfaces_[face_feature[f]].type == SurfaceType::Freeform) faces[face_feature[f]].push_back(f);
  for (const auto& [feature, list] : faces) {
    progress_.check();
    std::map<int, double> vertex_weight;
    MatrixX3d normals(static_cast<Eigen::Index>(list.size()), 3);
    for (size_t i = 0; i < list.size(); ++i) {
      const Vec3 a = mesh.V.row(mesh.F(list[i], 0)), b = mesh.V.row(mesh.F(list[i], 1)), c = mesh.V.row(mesh.F(list[i], 2));
      const Vec3 area_normal = 0.5 * (b - a).cross(c - a);
      normals.row(static_cast<Eigen::Index>(i)) = area_normal.normalized().transpose();
      for (int k = 0; k < 3; ++k) vertex_weight[mesh.F(list[i], k)] += area_normal.norm() / 3.0;
    }
    MatrixX3d points(static_cast<Eigen::Index>(vertex_weight.size()), 3);
    Eigen::VectorXd weights(static_cast<Eigen::Index>(vertex_weight.size()));
    Eigen::Index row = 0;
    for (const auto& [v, w] : vertex_weight) {
      points.row(row) = mesh.V.row(v);
      weights[row++] = w;
    }
    const BSplineSurfaceFit fit = fit_bspline_surface(points, weights, normals);
    if (!fit.valid) {
      result.problems.push_back({feature, fit.problem});
      continue;
    }
    try {
      freeform_[feature] = {occt_bspline(fit), fit.origin, fit.u_direction, fit.v_direction, fit.extrusion};
    } catch (const Standard_Failure& failure) {
      result.problems.push_back({feature, occt_message(failure, "the B-spline surface could not be made")});
    }
  }
}

LocalSurface BrepBuilder::local_surface(int feature) const {
  const auto spline = freeform_.find(feature);
  if (spline != freeform_.end()) {
    const FreeformSurface* f = &spline->second;
    return [f](const Vec3& p) { return f->tangent_plane(p); };
  }
  const Surface* s = &surfaces_[feature];
  return [s](const Vec3&) { return *s; };
}

BrepResult BrepBuilder::run(const std::vector<int>& labels, const BrepOptions& options) {
  BrepResult result;
  progress_.step(0.0);  // a cancelled Progress stops here, before any work
  auto since = Clock::now();
  const std::vector<int> clean_labels = clean_mesh(labels);
  long long mesh_edges = 0;  // for the Euler characteristic
  {
    const std::vector<std::int64_t> edges = sorted_edges(clean_);
    for (size_t i = 0; i < edges.size() && !open_mesh_; ++i)
      open_mesh_ = (i == 0 || edges[i] != edges[i - 1]) && (i + 1 == edges.size() || edges[i] != edges[i + 1]);
    mesh_edges = facet_edge_count(edges);
  }
  progress_.step(0.05);
  const MeshTopology topology(clean_);
  progress_.step(0.15);
  std::vector<int> face_feature = face_features(topology, clean_labels);
  progress_.step(0.35);
  const auto trace = [&](const std::vector<int>& features) {
    topo_ = trace_boundaries(clean_, topology, features);
    region_faces_.assign(topo_.region_feature.size(), {});
    for (int f = 0; f < clean_.num_faces(); ++f) region_faces_[topo_.face_region[f]].push_back(f);
  };
  trace(face_feature);
  const std::vector<int> joined = join_explained_regions(face_feature, result);
  if (joined != face_feature) trace(joined);
  face_feature = joined;
  stage(result, "brep.topology", since);
  progress_.step(0.45);

  progress_.sub("vertices", 0.0, 1.0).step(0.5);
  fit_freeform_surfaces(clean_, face_feature, result);
  make_vertices(topology);
  make_region_surfaces();
  compute_curves();
  measure_fits();
  stage(result, "brep.edges", since);
  degrade_in_rounds(result, options);
  check_euler_characteristic(result, mesh_edges);
  stage(result, "brep.faces", since);
  report_regions(result);
  return result;
}

// The mesh without the triangles whose corners coincide (no area, no topology); returns their
// labels.
std::vector<int> BrepBuilder::clean_mesh(const std::vector<int>& labels) {
  TriangleMesh& clean = clean_;
  std::vector<int> clean_labels;
  clean.V = mesh_.V;
  std::vector<int> kept;
  for (int f = 0; f < mesh_.num_faces(); ++f) {
    const int a = mesh_.F(f, 0), b = mesh_.F(f, 1), c = mesh_.F(f, 2);
    if (a != b && b != c && a != c) kept.push_back(f);
  }
  clean.F.resize(static_cast<Eigen::Index>(kept.size()), 3);
  for (size_t i = 0; i < kept.size(); ++i) {
    clean.F.row(static_cast<Eigen::Index>(i)) = mesh_.F.row(kept[i]);
    clean_labels.push_back(labels[kept[i]]);
  }
  return clean_labels;
}

// The feature of every triangle of the clean mesh, features on one surface merged and sampling
// blends dissolved; a part of the mesh that no feature reaches is one more, freeform, feature: a
// B-spline fitted to it, or its facets.
std::vector<int> BrepBuilder::face_features(const MeshTopology& topology, const std::vector<int>& clean_labels) {
  const TriangleMesh& clean = clean_;
  const std::vector<int> merged = dissolve_sampling_blends(clean, topology, merge_same_surfaces(clean_labels));
  progress_.step(0.25);
  const int unexplained = static_cast<int>(surfaces_.size());
  const std::vector<int> face_feature = complete_face_features(clean, topology, merged, surfaces_, tol_, 0.1, unexplained);
  if (std::count(face_feature.begin(), face_feature.end(), unexplained)) {
    Surface freeform;
    freeform.type = SurfaceType::Freeform;
    surfaces_.push_back(freeform);
  }
  return face_feature;
}

// One surface per region, oriented against the mesh normals, its seam away from its face (or shared
// with a neighbour that winds round the same axis).
void BrepBuilder::make_region_surfaces() {
  const TriangleMesh& clean = clean_;
  const int regions = static_cast<int>(topo_.region_feature.size());
  std::vector<std::vector<Vec3>> region_points(regions);
  region_sense_.assign(regions, 0.0);
  region_centroid_.assign(regions, Vec3::Zero());
  for (int f = 0; f < clean.num_faces(); ++f) {
    const int r = topo_.face_region[f];
    const Vec3 a = clean.V.row(clean.F(f, 0)), b = clean.V.row(clean.F(f, 1)), c = clean.V.row(clean.F(f, 2));
    const Vec3 centre = (a + b + c) / 3.0;
    const Vec3 area_normal = 0.5 * (b - a).cross(c - a);
    region_points[r].push_back(centre);
    const Surface& s = surfaces_[topo_.region_feature[r]];
    // OCCT's normal of a spindle torus turns inward on the lemon, beyond the axis, where the
    // parametrization's u direction reverses. (A lemon whose centre circle lies within the
    // tolerance of the axis is a sphere as much as the torus's other part, which OCCT then takes.)
    const double occt_sense = s.type == SurfaceType::Torus && s.radius < -tol_ ? -1.0 : 1.0;
    if (s.type != SurfaceType::Freeform) {
      region_sense_[r] += occt_sense * surface_normal(s, centre).dot(area_normal);
    } else if (const auto spline = freeform_.find(topo_.region_feature[r]); spline != freeform_.end()) {
      region_sense_[r] += spline->second.tangent_plane(centre).axis.dot(area_normal);
    }
  }
  region_surfaces_.resize(regions);
  region_winds_.assign(regions, 0);
  std::vector<std::optional<RoundFace>> rounds(regions);
  for (int r = 0; r < regions; ++r) {
    for (const Vec3& p : region_points[r]) region_centroid_[r] += p / static_cast<double>(region_points[r].size());
    rounds[r] = round_face(r);
    region_winds_[r] = rounds[r] && rounds[r]->winds;
    if (region_winds_[r]) seam_splits_[rounds[r]->split] = r;
  }
  for (int r = 0; r < regions; ++r) {
    // A band beside a face that winds round the same axis takes its seam: healing then joins the
    // two seams at the vertex of the circle between them.
    std::optional<RoundFace>& round = rounds[r];
    for (const auto& loop : topo_.region_loops[r]) {
      const BoundaryChain& chain = topo_.chains[loop.front().chain];
      const int across = chain.left == r ? chain.right : chain.left;
      if (round && !round->winds && loop.size() == 1 && chain.closed && across >= 0 && region_winds_[across] &&
          rounds[across]->axis.cross(round->axis).norm() <= angle_eps_)
        round->seam = rounds[across]->seam;
    }
    const auto spline = freeform_.find(topo_.region_feature[r]);
    region_surfaces_[r] = spline != freeform_.end() ? Handle(Geom_Surface)(spline->second.surface)
                                                    : make_surface(surfaces_[topo_.region_feature[r]], region_points[r], round);
  }
}

// Graceful degradation, region by region. A region whose face fails (not made, not valid, or
// where the shell does not close) is first bounded by the mesh's border between it and its
// neighbours, moved onto their surfaces (its own surface stays); where it fails again, it is made
// of its triangles. Each round degrades at least one more region; the last facets them all, which
// closes whenever the mesh does.
void BrepBuilder::degrade_in_rounds(BrepResult& result, const BrepOptions& options) {
  const int regions = static_cast<int>(topo_.region_feature.size());
  constexpr int kRounds = 4;  // the rounds' time budget (below): 8 rounds at most, then every region faceted
  faceted_.assign(regions, 0);
  bounded_.assign(regions, 0);
  facet_reason_.assign(regions, "");
  for (int r = 0; r < regions; ++r)
    if (region_surfaces_[r].IsNull()) {
      faceted_[r] = 1;
      facet_reason_[r] = "no surface explains it (a freeform region without a fitted B-spline)";
    }
  const BrepResult prepared = result;
  // Each round starts from the corners as made: healing, sewing and the edges' ends raise the
  // tolerances of the vertices they are given (in place), which a later round must not inherit.
  std::map<int, std::pair<gp_Pnt, double>> corners_made;
  for (const auto& [v, vertex] : vertices_) corners_made[v] = {BRep_Tool::Pnt(vertex), BRep_Tool::Tolerance(vertex)};
  for (int round = 0;; ++round) {
    if (round > 0) {
      // (Corners merged into one vertex stay one: those that shared a vertex share its copy.)
      std::map<const TopoDS_TShape*, TopoDS_Vertex> fresh;
      for (auto& [v, vertex] : vertices_) {
        TopoDS_Vertex& copy = fresh[vertex.TShape().get()];
        if (copy.IsNull()) BRep_Builder().MakeVertex(copy, corners_made[v].first, corners_made[v].second);
        vertex = copy;
      }
    }
    const bool all = std::all_of(faceted_.begin(), faceted_.end(), [](char f) { return f != 0; });
    result = prepared;
    failed_.clear();
    polyline_.assign(topo_.chains.size(), 0);
    for (size_t c = 0; c < topo_.chains.size(); ++c) {
      const BoundaryChain& chain = topo_.chains[c];
      // (A chain whose corners are one vertex is no edge, also beside a facet: place_polylines
      // gives its vertices that one vertex.)
      polyline_[c] = !collapsed_[c] && (faceted_[chain.left] || bounded_[chain.left] ||
                     (chain.right >= 0 && (faceted_[chain.right] || bounded_[chain.right])) ||
                     curves_[c].curve.IsNull());
    }
    bool done = false;
    try {
      OCC_CATCH_SIGNALS
      place_polylines();
      done = build_round(result, options);
    } catch (const Standard_Failure& failure) {
      // A round that OpenCASCADE gives up on: every region left is faceted in the next.
      if (all) throw;
      for (int r = 0; r < regions; ++r)
        if (!faceted_[r]) {
          faceted_[r] = 1;
          facet_reason_[r] = occt_message(failure, "the construction failed");
        }
      continue;
    }
    if (done || all) break;
    // An open mesh does not close however its faces are made: only faces that fail degrade.
    if (open_mesh() && failed_.empty()) break;
    bool more = false;
    // A face bounded by the mesh's border is worth a round only while such faces hold in this
    // part: once every one tried has failed, a region that fails is faceted at once.
    int bounded_tried = 0, bounded_failed = 0;
    for (int r = 0; r < regions; ++r)
      if (bounded_[r]) {
        ++bounded_tried;
        bounded_failed += faceted_[r] || failed_.count(r);
      }
    const bool bound_first = bounded_tried == 0 || bounded_failed < bounded_tried;
    // A failure of the first kRounds - 1 rounds is bounded first, a later one faceted at once; a
    // failure of round 2 kRounds - 1 facets every region left (which closes whenever the mesh does).
    const bool last = round + 1 >= kRounds;
    for (const auto& [r, why] : failed_) {
      if (faceted_[r]) continue;
      more = true;
      if (!bounded_[r] && !region_surfaces_[r].IsNull() && bound_first && !last) {
        bounded_[r] = 1;
        facet_reason_[r] = why;
        continue;
      }
      faceted_[r] = 1;
      facet_reason_[r] = facet_reason_[r].empty() ? why : facet_reason_[r] + "; bounded by the mesh's border: " + why;
    }
    if (!more || round + 1 >= 2 * kRounds)
      for (int r = 0; r < regions; ++r)
        if (!faceted_[r]) {
          faceted_[r] = 1;
          facet_reason_[r] = facet_reason_[r].empty() ? "the shell did not close with its analytic face"
                                                      : facet_reason_[r] + "; then the shell did not close";
        }
  }
}

// The closed shape against the mesh: as many bodies and handles (thesis 4.3.3: the topology is
// the mesh's). Collapsed chains and joined regions leave it unchanged; a loop lost with all its
// chains collapsed (a hole narrower than the tolerance) does not. `edge_count`: the clean mesh's
// (facet_edge_count).
void BrepBuilder::check_euler_characteristic(BrepResult& result, long long edge_count) const {
  if (!result.solid || result.shape.IsNull()) return;
  std::vector<char> used(clean_.num_vertices(), 0);
  for (int f = 0; f < clean_.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) used[clean_.F(f, k)] = 1;
  result.euler_mesh = static_cast<int>(std::count(used.begin(), used.end(), 1) - edge_count + clean_.num_faces());
  result.euler_shape = euler_characteristic(result.shape);
  if (result.euler_shape != result.euler_mesh)
    result.problems.push_back({-1, "the solid's Euler characteristic " + std::to_string(result.euler_shape) +
                                       " differs from the mesh's " + std::to_string(result.euler_mesh) +
                                       " (a handle or a body appeared or vanished)"});
}

// What became of each region, and the features of the result named as the layer's (-1 for the
// feature added for what none explained).
void BrepBuilder::report_regions(BrepResult& result) const {
  const int regions = static_cast<int>(topo_.region_feature.size());
  const Eigen::VectorXd areas = face_areas(clean_);
  double total = 0.0, analytic = 0.0;
  for (int r = 0; r < regions; ++r) {
    BrepRegionFace face;
    face.feature = topo_.region_feature[r];
    for (int f : region_faces_[r]) face.area += areas[f];
    face.kind = faceted_[r] ? "faceted" : freeform_.count(face.feature) ? "bspline" : "analytic";
    face.reason = faceted_[r] ? facet_reason_[r] : "";
    total += face.area;
    if (face.kind == "analytic") analytic += face.area;
    result.regions.push_back(face);
  }
  result.analytic_area_fraction = total > 0 ? analytic / total : 0.0;
  // The feature added for what no feature explained is none of the layer's.
  const auto layer_feature = [&](int& feature) {
    if (feature >= features_) feature = -1;
  };
  for (BrepProblem& problem : result.problems) layer_feature(problem.feature);
  for (int& feature : result.face_features) layer_feature(feature);
  for (BrepRegionFace& face : result.regions) layer_feature(face.feature);
  for (BrepEdge& edge : result.edges) {
    layer_feature(edge.a);
    layer_feature(edge.b);
  }
}

// One attempt with the regions faceted so far: edges, faces, the shell and its checks. Returns
// whether it gave a valid closed solid; the regions that failed are in failed_.
bool BrepBuilder::build_round(BrepResult& result, const BrepOptions& options) {
  auto since = Clock::now();
  make_edges(result);
  make_faces(result);
  stage(result, "brep.round.faces", since);
  std::vector<std::string> closed_faults;
  TopoDS_Shape shape = assemble(result, options, closed_faults);
  stage(result, "brep.sew", since);
  const ProgressSpan checking = progress_.sub("checking", 0.9, 1.0);
  checking.step(0.0);

  // Validated by assemble, a closed solid's faces by closed_shell_faults; an invalid result keeps
  // only its valid faces, as a shell (never an invalid solid).
  result.solid = result.valid && result.closed && is_solid_shape(shape);
  if (result.solid && closed_faults.empty()) {
    try {
      OCC_CATCH_SIGNALS
      closed_faults = closed_shell_faults(
          shape, 0.01 * diagonal_, tol_, [&](const TopoDS_Face& face) { return is_facet(face); }, checking.sub(0.0, 0.2));
    } catch (const Standard_Failure& failure) {
      result.problems.push_back({-1, occt_message(failure, "the solid's faces could not be meshed")});
      result.solid = false;  // (no face to blame: the boolean operations' checks decide what stays)
    }
  }
  result.solid = result.solid && no_faults(closed_faults);
  bool deviates = false;
  if (result.solid) {
    GProp_GProps properties;
    BRepGProp::VolumeProperties(shape, properties);
    result.volume = std::abs(properties.Mass());
    // Valid and closed is not enough: the solid must also lie where the mesh does.
    result.solid = follows_mesh(shape, result, checking.sub(0.2, 0.5));
    // A valid closed shape that only lies off its mesh keeps its faces: the regions that deviate
    // are degraded, not the faces the boolean operations' stricter check would also reject.
    deviates = !result.solid;
    if (!result.solid) result.volume = 0.0;
  }
  if (!result.solid && !deviates) {
    // Only the faces that pass the boolean operations' checks are kept (shell_face_fault, which
    // only reads them: on two threads).
    std::vector<TopoDS_Face> sewn_faces;
    for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next()) sewn_faces.push_back(TopoDS::Face(e.Current()));
    std::vector<std::string> faults(sewn_faces.size());
    on_two_threads_as_free(static_cast<int>(sewn_faces.size()), [&](int i) {
      if (static_cast<size_t>(i) < closed_faults.size() && !closed_faults[i].empty()) {
        faults[i] = closed_faults[i];
        return;
      }
      if (is_facet(sewn_faces[i])) return;  // valid by construction
      try {
        OCC_CATCH_SIGNALS
        faults[i] = shell_face_fault(sewn_faces[i], diagonal_);
      } catch (const Standard_Failure& failure) {
        faults[i] = occt_message(failure, "its check failed");
      }
    }, progress_);
    BRep_Builder builder;
    TopoDS_Compound kept_faces;
    builder.MakeCompound(kept_faces);
    bool dropped = false;
    for (size_t i = 0; i < sewn_faces.size(); ++i) {
      const std::string& reason = faults[i];
      if (reason.empty()) {
        builder.Add(kept_faces, sewn_faces[i]);
      } else {
        dropped = true;
        const std::string message = "its face is not valid (" + reason + ")";
        const int region = region_of(sewn_faces[i]);
        // Never dropped silently, also where no feature is known.
        fail(region, message);
        if (region >= 0)
          result.problems.push_back({topo_.region_feature[region], message});
        else
          result.problems.push_back({-1, std::string("a ") + occt_surface_name(sewn_faces[i]) + " face: " + message.substr(4)});
      }
    }
    if (!dropped && !result.valid) {
      // Each face passes alone and the whole does not: the faces where they meet are to blame.
      try {
        OCC_CATCH_SIGNALS
        for (const FaceFault& fault : faces_at_fault(shape, [&](const TopoDS_Face& face) { return is_facet(face); })) {
          const int region = region_of(fault.face);
          fail(region, fault.reason);
          result.problems.push_back({region >= 0 ? topo_.region_feature[region] : -1, fault.reason});
        }
      } catch (const Standard_Failure& failure) {
        result.problems.push_back({-1, occt_message(failure, "the solid's check failed")});
      }
    }
    if (dropped || !result.valid) {  // the sewn shell when it is valid and every face is kept
      shape = kept_faces;
      result.valid = valid(shape, checking.sub(0.6, 0.9));  // what is returned: the valid faces
      result.closed = result.closed && !dropped;
    }
  }
  if (!result.closed) {
    result.problems.push_back({-1, "the faces do not close into a solid (free edges remain)"});
  }
  if (!result.closed && failed_.empty() && !open_mesh()) {
    // No face failed on its own: the faces along the free edges.
    TopTools_IndexedDataMapOfShapeListOfShape faces_of_edge;
    TopExp::MapShapesAndUniqueAncestors(shape, TopAbs_EDGE, TopAbs_FACE, faces_of_edge);
    for (int i = 1; i <= faces_of_edge.Extent(); ++i) {
      const TopTools_ListOfShape& faces = faces_of_edge(i);
      if (BRep_Tool::Degenerated(TopoDS::Edge(faces_of_edge.FindKey(i))) || faces.Extent() != 1) continue;
      const TopoDS_Face& face = TopoDS::Face(faces.First());
      if (BRep_Tool::IsClosed(TopoDS::Edge(faces_of_edge.FindKey(i)), face)) continue;
      fail(region_of(face), "the shell does not close along its boundary");
    }
  }
  result.shape = shape;
  for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next()) {
    const TopoDS_Face& face = TopoDS::Face(e.Current());
    ++result.faces;
    const int region = region_of(face);
    ++result.surface_types[region >= 0 && faceted_[region] ? "facet" : occt_surface_name(face)];
    result.face_features.push_back(region < 0 ? -1 : topo_.region_feature[region]);
  }
  for (TopExp_Explorer e(shape, TopAbs_VERTEX); e.More(); e.Next())
    result.max_tolerance = std::max(result.max_tolerance, BRep_Tool::Tolerance(TopoDS::Vertex(e.Current())));
  for (TopExp_Explorer e(shape, TopAbs_EDGE); e.More(); e.Next())
    result.max_tolerance = std::max(result.max_tolerance, BRep_Tool::Tolerance(TopoDS::Edge(e.Current())));
  checking.step(0.6);
  stage(result, "brep.check", since);
  checking.step(1.0);
  return result.solid;
}

BrepResult build_brep(const TriangleMesh& mesh, const std::vector<int>& labels,
                      const std::vector<Surface>& surfaces, const BrepOptions& options) {
  if (static_cast<int>(labels.size()) != mesh.num_faces()) {
    throw std::invalid_argument("build_brep: one label per triangle expected");
  }
  for (int l : labels) {
    if (l >= static_cast<int>(surfaces.size())) throw std::invalid_argument("build_brep: label without a surface");
  }
  // OpenCASCADE's healing and checking dereference null pointers on some inputs; with its signal
  // handlers installed for the duration of the call such a fault becomes an exception (thrown at
  // the nearest OCC_CATCH_SIGNALS) instead of taking the user's FreeCAD down.
  const OcctSignalHandlers handlers;
  try {
    OCC_CATCH_SIGNALS
    return BrepBuilder(mesh, surfaces, options).run(labels, options);
  } catch (const Standard_Failure& failure) {
    throw std::runtime_error(occt_message(failure, "B-rep construction failed"));
  }
}


}  // namespace idealize
