// Honest validity: the solid lies where its mesh does (deviation.h) (builder.h).
#include "brep/builder.h"

namespace idealize {

double noise_sigma(std::vector<double> residuals) {
  if (residuals.empty()) return 0.0;
  std::nth_element(residuals.begin(), residuals.begin() + residuals.size() / 2, residuals.end());
  return 1.4826 * residuals[residuals.size() / 2];
}

// What the honest-validity check measures once: how far each region's mesh may lie from its
// surface where the surface explains it (the sagitta of its triangles and the extent of the
// mesh's noise), each curve's distance from its chain (a sharp edge laid over a rounded one), and
// the volume the mesh encloses.
void BrepBuilder::measure_fits() {
  const int regions = static_cast<int>(topo_.region_feature.size());
  region_fit_.assign(regions, 0.0);
  std::vector<double> residuals;  // of every vertex of a region with a surface, for the noise
  std::vector<int> counts(regions, 0);
  std::vector<char> seen(clean_.num_vertices(), 0);
  for (int r = 0; r < regions; ++r) {
    progress_.check();
    if (region_surfaces_[r].IsNull()) continue;
    const LocalSurface surface = local_surface(topo_.region_feature[r]);
    const auto distance = [&](const Vec3& p) { return std::abs(signed_distance(surface(p), p)); };
    for (int f : region_faces_[r]) {
      double corners = 0.0;
      for (int k = 0; k < 3; ++k) {
        const int v = clean_.F(f, k);
        const double d = distance(clean_.V.row(v).transpose());
        corners += d / 3.0;
        if (seen[v] != 1 + (r & 1)) {  // (each vertex once per region, near enough)
          seen[v] = static_cast<char>(1 + (r & 1));
          residuals.push_back(d);
          ++counts[r];
        }
      }
      // The sagitta: how far the triangle's middle lies from the surface beyond its corners (a
      // curved surface's chord; 0 on a plane).
      const Vec3 middle = face_centroid(clean_, f);
      region_fit_[r] = std::max(region_fit_[r], distance(middle) - corners);
    }
  }
  // The noise (noise_sigma). The largest of n Gaussian residuals is about sigma sqrt(2 ln n).
  const double sigma = noise_sigma(std::move(residuals));
  region_noise_.assign(regions, 0.0);
  for (int r = 0; r < regions; ++r) {
    if (counts[r] > 1) region_noise_[r] = sigma * std::sqrt(2.0 * std::log(static_cast<double>(counts[r])));
    region_fit_[r] += region_noise_[r];
  }
  chain_gap_.assign(topo_.chains.size(), 0.0);
  on_two_threads_as_free(static_cast<int>(topo_.chains.size()), [&](int c) {
    const ChainCurve& curve = curves_[c];
    if (curve.curve.IsNull()) return;
    const std::vector<int>& chain = topo_.chains[c].vertices;
    // One vertex in 64 or more: the gap varies slowly along a chain (its surfaces' fits do).
    const size_t step = std::max<size_t>(1, chain.size() / 64);
    for (size_t i = 0; i < chain.size(); i += step) {
      GeomAPI_ProjectPointOnCurve projection(to_pnt(clean_.V.row(chain[i]).transpose()), curve.curve);
      if (projection.NbPoints() > 0) chain_gap_[c] = std::max(chain_gap_[c], projection.LowerDistance());
    }
  }, progress_);
  mesh_volume_ = open_mesh() ? 0.0 : std::abs(enclosed_volume(clean_));
}

// Per region, the distance its face and its mesh may lie apart: the larger of its fit and of the
// gaps between its border and the edges and corners that replace it, plus the tolerance and the
// sampling's deflection. A region its surface does not explain (a strip of another feature's
// triangles in it) lies farther: its face fails. (A faceted region's fit is 0: its facets are its
// triangles.)
std::vector<double> BrepBuilder::deviation_allowances(double deflection, std::vector<double>* border) const {
  const int regions = static_cast<int>(topo_.region_feature.size());
  std::vector<double> allow(regions, 0.0);
  const auto raw = [&](int v) { return Vec3(clean_.V.row(v).transpose()); };
  std::vector<double> gaps(topo_.chains.size(), 0.0);
  std::map<int, double> corner_reach;  // corner -> the widest gap of the chains that end there
  for (size_t c = 0; c < topo_.chains.size(); ++c) {
    const BoundaryChain& chain = topo_.chains[c];
    gaps[c] = polyline_[c] ? 0.0 : chain_gap_[c];
    if (polyline_[c] && facets_)
      for (int v : chain.vertices) gaps[c] = std::max(gaps[c], (facets_->position(v) - raw(v)).norm());
    if (!chain.closed)
      for (int v : {chain.vertices.front(), chain.vertices.back()}) corner_reach[v] = std::max(corner_reach[v], gaps[c]);
  }
  for (size_t c = 0; c < topo_.chains.size(); ++c) {
    const BoundaryChain& chain = topo_.chains[c];
    double gap = gaps[c];
    // A corner lies off the mesh's as far as its edges let it: a ball-rounded corner of three square
    // faces lies 1.77 times as far from the sharp corner as its rounded edges from theirs
    // ((sqrt 3 - 1) / (sqrt 2 - 1)), so twice their widest gap. A corner farther off (surfaces
    // meeting nearly parallel put it anywhere along their near-intersection) is not the mesh's.
    if (!chain.closed)
      for (int v : {chain.vertices.front(), chain.vertices.back()})
        if (const auto corner = corner_points_.find(v); corner != corner_points_.end())
          gap = std::max(gap, std::min((corner->second - raw(v)).norm(), 2.0 * corner_reach[v]));
    for (int r : {chain.left, chain.right})
      if (r >= 0) allow[r] = std::max(allow[r], gap);
  }
  // (allow holds the border's gaps so far: the border allowance.)
  if (border) *border = allow;
  for (int r = 0; r < regions; ++r) allow[r] = std::max(allow[r], faceted_[r] ? 0.0 : region_fit_[r]);
  for (double& a : allow) a += tol_ + deflection;
  if (border)
    for (double& a : *border) a += tol_ + deflection;
  return allow;
}

// Whether a closed solid lies where its mesh does (deviation.h). A face farther from the mesh, or
// a region whose vertices lie farther from the solid, than its allowance fails its region; a volume
// that differs from the mesh's by more than the allowances over the regions' areas can account for
// fails the solid.
bool BrepBuilder::follows_mesh(const TopoDS_Shape& shape, BrepResult& result, const ProgressSpan& progress) {
  const double deflection = tol_;  // samples within the tolerance of the faces
  std::vector<double> gap;
  const std::vector<double> allow = deviation_allowances(deflection, &gap);
  const double widest = allow.empty() ? tol_ : *std::max_element(allow.begin(), allow.end());
  std::vector<TopoDS_Face> faces;
  std::vector<int> face_regions;
  for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next()) {
    const TopoDS_Face& face = TopoDS::Face(e.Current());
    if (is_facet(face)) continue;
    faces.push_back(face);
    face_regions.push_back(region_of(face));
  }
  // (A faceted region's triangles stand for its facets, whose border vertices may have moved by up
  // to their gap onto the surfaces beside them: within the allowances.)
  std::vector<int> facet_triangles, query, query_index(clean_.num_vertices(), -1);
  for (int f = 0; f < clean_.num_faces(); ++f) {
    if (faceted_[topo_.face_region[f]]) {
      facet_triangles.push_back(f);
      continue;
    }
    for (int k = 0; k < 3; ++k)
      if (query_index[clean_.F(f, k)] < 0) {
        query_index[clean_.F(f, k)] = static_cast<int>(query.size());
        query.push_back(clean_.F(f, k));
      }
  }
  const ShapeMeshDistance distance = shape_mesh_distance(faces, clean_, facet_triangles, query, deflection, progress);
  bool follows = true;
  const auto fault = [&](int region, const char* what, double d, double allowed) {
    std::ostringstream message;
    message << what << d << ", beyond the " << allowed << " that its fit and its border allow";
    follows = false;
    fail(region, message.str());
    result.problems.push_back({region >= 0 ? topo_.region_feature[region] : -1, message.str()});
  };
  result.deviation_bound = widest;
  for (size_t i = 0; i < faces.size(); ++i) {
    const int r = face_regions[i];
    const double allowed = r >= 0 ? allow[r] : widest;
    result.shape_to_mesh = std::max(result.shape_to_mesh, distance.face_to_mesh[i]);
    if (distance.face_to_mesh[i] > allowed) fault(r, "its face lies off the mesh by ", distance.face_to_mesh[i], allowed);
  }
  // A mesh vertex lies no farther from the solid than from its region's surface, beyond the gaps
  // along the region's border: farther, a face is missing or cut short (its trimming is wrong).
  std::vector<double> region_off(allow.size(), 0.0), region_excess(allow.size(), 0.0);
  std::vector<std::vector<double>> offs(allow.size());
  for (int r = 0; r < static_cast<int>(allow.size()); ++r) {
    if (faceted_[r] || region_faces_[r].empty()) continue;
    const LocalSurface surface = local_surface(topo_.region_feature[r]);
    for (int f : region_faces_[r])
      for (int k = 0; k < 3; ++k) {
        const Vec3 p = clean_.V.row(clean_.F(f, k));
        const double d = distance.vertex_to_shape[query_index[clean_.F(f, k)]];
        region_off[r] = std::max(region_off[r], d);
        region_excess[r] = std::max(region_excess[r], d - std::abs(signed_distance(surface(p), p)));
        offs[r].push_back(d);
      }
  }
  for (size_t r = 0; r < allow.size(); ++r) {
    result.mesh_to_shape = std::max(result.mesh_to_shape, region_off[r]);
    if (failed_.count(static_cast<int>(r)) || offs[r].empty()) continue;
    // Most of a region lies within the noise of its face: a face moved off its mesh as a whole
    // (its edges then follow it, and their gaps would excuse it) fails here.
    std::nth_element(offs[r].begin(), offs[r].begin() + offs[r].size() / 2, offs[r].end());
    const double median = offs[r][offs[r].size() / 2], noise = region_noise_[r] + tol_ + deflection;
    if (region_excess[r] > gap[r])
      fault(static_cast<int>(r), "its mesh lies farther off the solid than off its surface by ", region_excess[r], gap[r]);
    else if (median > noise)
      fault(static_cast<int>(r), "half its mesh lies off the solid by more than ", median, noise);
  }
  if (follows && mesh_volume_ > 0) {
    // Two surfaces within distance d of each other over an area A enclose volumes at most A d apart.
    const Eigen::VectorXd areas = face_areas(clean_);
    double slack = 0.0;
    for (int f = 0; f < clean_.num_faces(); ++f) slack += areas[f] * allow[topo_.face_region[f]];
    result.mesh_volume = mesh_volume_;
    if (std::abs(result.volume - mesh_volume_) > slack) {
      std::ostringstream message;
      message << "the solid's volume " << result.volume << " differs from the mesh's " << mesh_volume_
              << " by more than its faces' allowances account for (" << slack << ")";
      result.problems.push_back({-1, message.str()});
      follows = false;
    }
  }
  return follows;
}

}  // namespace idealize
