// Merging adjacent patches that one surface fits together.
#include "features/merge.h"

#include "core/parallel.h"
#include "features/exact_fragments.h"
#include "features/feature_graph.h"
#include "features/identify.h"
#include "features/pipeline.h"
#include "fit/fits_as_well.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <set>

namespace idealize {

bool surfaces_meet_at_border(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<int>& labels,
                             int a, int b, const Surface& sa, const Surface& sb, double distance_a, double distance_b) {
  std::vector<double> da, db;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (labels[f] != a) continue;
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g < 0 || labels[g] != b) continue;
      for (int k : {1, 2}) {  // the edge opposite corner c
        const Eigen::Vector3d v = mesh.V.row(mesh.F(f, (c + k) % 3)).transpose();
        da.push_back(std::abs(signed_distance(sa, v)));
        db.push_back(std::abs(signed_distance(sb, v)));
      }
    }
  }
  if (da.empty()) return false;
  auto median = [](std::vector<double>& x) {
    std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
    return x[x.size() / 2];
  };
  return median(da) <= distance_a && median(db) <= distance_b;
}

bool alike(const Feature& a, const Feature& b, double angle_tolerance, double distance_tolerance, double radius_tolerance) {
  if (a.type == SurfaceType::Freeform || b.type == SurfaceType::Freeform) return false;
  auto zone = [](SurfaceType t) { return t == SurfaceType::Cone || t == SurfaceType::Cylinder; };
  const bool torus_zone = (a.type == SurfaceType::Torus && zone(b.type)) || (b.type == SurfaceType::Torus && zone(a.type));
  if (a.type != b.type && !torus_zone) return false;
  if (a.surface.has_direction() && std::abs(a.surface.axis.dot(b.surface.axis)) < std::cos(angle_tolerance)) return false;
  if (torus_zone) return true;
  if (a.type == SurfaceType::Cone) return std::abs(a.surface.half_angle - b.surface.half_angle) <= angle_tolerance;
  return a.type == SurfaceType::Plane || equal_radii(a, b, distance_tolerance, radius_tolerance);
}

namespace {

enum class Verdict { kUnchanged, kAbsorbed, kMerged, kRejected };

struct Candidate {
  double cost;
  int a, b;
  Feature feature;
};

struct Judgement {
  Verdict verdict = Verdict::kUnchanged;
  Candidate candidate;  // kAbsorbed: (large, piece); kMerged: the pair and its surface
};

// One pair of adjacent patches under judgement: the two, which is the larger, and the limits a
// merge must meet.
struct Pair {
  int a, b;
  const Feature &fa, &fb;
  const PatchPoints &pa, &pb;
  bool a_small, b_small, same_type, a_larger;
  const Feature &larger, &smaller;
  const PatchPoints &larger_points, &smaller_points;
  bool larger_small;
  double limit, normal_limit;
  bool one_surface = false, one_plane = false;  // alike pieces that meet without a crease (judge)
  PatchPoints both;                              // the points of the two together
};

// Judges pairs of adjacent patches, reading the features, points and labels only (so pairs are
// judged on two threads).
struct PairJudge {
  const TriangleMesh& mesh;
  const MeshTopology& topology;
  const std::vector<PatchPoints>& points;
  const std::function<Feature(const PatchPoints&, const PatchCurvature&)>& identify_points;
  const FeatureOptions& options;
  double tolerance;
  bool exact;
  double exact_distance, noise;
  const std::vector<Feature>& features;
  const std::vector<int>& labels;
  const std::map<std::pair<int, int>, double>& turns;  // boundary_turns, with the turns inside
  double normal_floor, angle_tolerance;                 // radians

  double inside_turn(int p) const {
    const auto it = turns.find({p, p});
    return it == turns.end() ? 0.0 : it->second;
  }

  // A surface that the vertices of a large patch fix takes the neighbours it explains as it is,
  // several in one call: on an exact tessellation when it explains every point and the normals of
  // both together fit it as a merge would require (the fragments along a coarse torus); on a
  // noisy one a curved surface takes a large neighbour of another type that it fits about as well
  // as the neighbour's own surface (a zone of a torus that a sphere fits).
  bool absorbs(const Pair& q) const {
    const bool noisy_other_type = !exact && !q.same_type && !q.a_small && !q.b_small &&
                                  q.larger.type != SurfaceType::Plane;
    if (!(exact || noisy_other_type) || q.larger_small || q.larger.type == SurfaceType::Freeform) return false;
    SurfaceFit piece;
    piece.surface = q.larger.surface;
    measure_spreads(q.smaller_points, piece);
    if (exact) {
      const double w_larger = q.larger_points.sample_weights.sum(), w_smaller = q.smaller_points.sample_weights.sum();
      const double normal_rms = std::sqrt((w_larger * q.larger.normal_rms * q.larger.normal_rms +
                                           w_smaller * piece.normal_rms * piece.normal_rms) / (w_larger + w_smaller));
      const double angle = 3.0 * std::max(q.fa.normal_spread, q.fb.normal_spread) + normal_floor;
      return normal_rms <= q.normal_limit &&
             explains_every_point(q.larger.surface, q.smaller_points, exact_distance, angle, kLargestFacetTurn);
    }
    double rms, max_error;
    fit_residuals(q.larger.surface, q.smaller_points.points, q.smaller_points.weights, rms, max_error);
    return fits_as_well(rms, std::max(q.smaller.rms, noise), options.residual_ratio) &&
           piece.normal_rms <= q.normal_limit;
  }

  // Whether surface `u` may stand for both patches of the pair.
  bool accepted(const Pair& q, const Feature& u) const {
    if (u.type == SurfaceType::Freeform) return false;
    // (A curved union keeps to the normals' limit: the refit of two pieces of a narrow fillet may
    // flatten into a cylinder of 20 m, which then grows over the plane beside it.)
    const bool loose = !exact && q.one_surface && u.type == q.fa.type;
    if ((!loose && u.rms > q.limit) || (!(loose && q.one_plane) && u.normal_rms > q.normal_limit)) return false;
    if (!exact) {
      // An RMS over the union hides a small foreign part (a pocket's wall in a large plane, whose
      // RMS then lets the next one in).
      for (const auto& [part, own] : {std::pair{&q.pa, &q.fa}, std::pair{&q.pb, &q.fb}}) {
        double rms, max_error;
        fit_residuals(u.surface, part->points, part->weights, rms, max_error);
        if (!fits_as_well(rms, std::max(own->rms, noise), options.residual_ratio, tolerance))
          return q.one_plane && u.type == SurfaceType::Plane &&
                 surfaces_meet_at_border(mesh, topology, labels, q.a, q.b, q.fa.surface, q.fb.surface,
                                         std::max(tolerance, q.fa.max_error), std::max(tolerance, q.fb.max_error));
      }
      return true;
    }
    // Exact only with a point more than the surface's parameters fit anyway (the six vertices of
    // two creased quads lie on three lines through a point, and so on a cone).
    if (distinct_points(q.both) <= parameter_count(u.type)) return false;
    // As much normal spread as the parts have is allowed, plus the floor (and the facets' chords).
    const double angle = 3.0 * std::max(q.fa.normal_spread, q.fb.normal_spread) + normal_floor;
    const double chord_turn = q.larger_small ? kFewPointsChordTurn : kLargestFacetTurn;
    return explains_every_point(u.surface, q.pa, exact_distance, angle, chord_turn) &&
           explains_every_point(u.surface, q.pb, exact_distance, angle, chord_turn);
  }

  // Two pieces identified afresh as one; on an exact tessellation, where identification took a
  // sphere or a cone for two curved pieces of a lemon-shaped dome (a spindle torus's inner part)
  // that it does not explain, the torus, if it does, from the piece that is a lemon already if one
  // is. (Planar facets tell no curvature: the few points of two fit a lemon of any shape.)
  bool identify_union(const Pair& q, Feature& merged) const {
    merged = identify_points(q.both, q.larger.curvature);
    bool ok = accepted(q, merged);
    auto curved = [](SurfaceType t) { return t != SurfaceType::Plane && t != SurfaceType::Freeform; };
    auto lemon_piece = [](const Feature& f) { return f.type == SurfaceType::Torus && f.surface.radius < 0.0; };
    const Surface* start = lemon_piece(q.fa) ? &q.fa.surface : lemon_piece(q.fb) ? &q.fb.surface : nullptr;
    if (exact && !ok && curved(merged.type) && (merged.type != SurfaceType::Torus || start) && curved(q.fa.type) &&
        curved(q.fb.type)) {
      if (const std::optional<SurfaceFit> lemon = fit_lemon(q.both, options.fit, tolerance, exact_distance, start)) {
        Feature torus = merged;
        torus.set_fit(*lemon);
        if ((ok = accepted(q, torus))) merged = torus;
      }
    }
    return ok;
  }

  // On a noisy mesh, two planes may be the halves of a narrow fillet, each as flat as the noise
  // lets it look: a curved surface joins them when its normals fit the union better than either
  // plane's fit its own half (two faces of a real edge fit their planes better), and its
  // distances no worse. Most pairs of planes are faces of a real edge: only planes that turn by
  // less than 60° (the halves of a rounded edge of up to 120°) are tried, and the other curved
  // types only where a cylinder bends the right way but does not fit (measured on the benchmark's
  // scans: 3 of 1242 pairs merged, all within 40°; fitting them all doubled the merging time).
  bool curved_halves(const Pair& q, Feature& merged) const {
    const double plane_normal_rms = std::min(q.fa.normal_rms, q.fb.normal_rms);
    for (SurfaceType type : {SurfaceType::Cylinder, SurfaceType::Cone, SurfaceType::Sphere, SurfaceType::Torus}) {
      const SurfaceFit fit = fit_surface(type, q.both, options.fit);
      if (!fit.valid) continue;
      Feature curved = q.larger;
      curved.set_fit(fit);
      const bool bends = curved.normal_rms < plane_normal_rms;
      if (bends && curved.rms <= std::max(q.fa.rms, q.fb.rms) && accepted(q, curved)) {
        merged = curved;
        return true;
      }
      if (type == SurfaceType::Cylinder && !bends) break;
    }
    return false;
  }

  Judgement judge(int a, int b, const std::set<std::pair<int, int>>& rejected) const;
};

Judgement PairJudge::judge(int a, int b, const std::set<std::pair<int, int>>& rejected) const {
  if (rejected.count({a, b})) return {};  // neither changed since
  const Feature &fa = features[a], &fb = features[b];
  const PatchPoints &pa = points[a], &pb = points[b];
  const bool a_larger = pa.weights.sum() >= pb.weights.sum();
  const bool a_small = pa.points.rows() < kInteriorPoints, b_small = pb.points.rows() < kInteriorPoints;
  Pair q{a, b, fa, fb, pa, pb, a_small, b_small,
         fa.type == fb.type && fa.type != SurfaceType::Freeform, a_larger,
         a_larger ? fa : fb, a_larger ? fb : fa, a_larger ? pa : pb, a_larger ? pb : pa,
         a_larger ? a_small : b_small,
         accepted_residual(std::max(fa.rms, fb.rms), options.residual_ratio, kExactFraction * tolerance),
         accepted_residual(std::max(fa.normal_rms, fb.normal_rms), options.residual_ratio, normal_floor), false, false, {}};
  if (absorbs(q)) return {Verdict::kAbsorbed, {0.0, a_larger ? a : b, a_larger ? b : a, Feature()}};
  // Two large patches of different types make one surface only on an exact tessellation: a coarse
  // torus falls into bands between its meridians, each of which a cylinder or cone fits exactly.
  if (!q.same_type && !a_small && !b_small && !exact) return {};
  // On a noisy mesh, two cylinders of one radius whose axes turn may be sectors of another surface
  // that the histogram cut up: a torus's tube (a wide blend whose mean curvature passes through
  // zero), a slender cone. Their union is identified afresh.
  const bool sectors = !exact && q.same_type && fa.type == SurfaceType::Cylinder &&
                       std::abs(fa.surface.axis.dot(fb.surface.axis)) < std::cos(angle_tolerance) &&
                       equal_radii(fa, fb, tolerance, options.radius_tolerance);
  // Two alike pieces (planes within the angle tolerance; coaxial cylinders of one radius, and so
  // on) that meet without a crease (no facet turns more across their border than inside either)
  // are one surface where it explains each part (accepted), or, planes, where both pass through
  // their border as closely as through their own points (not a step): a sculpted face's undulation
  // bends it by more than its pieces' fits allow a merge (a sculpted fillet in two pieces 1.5°
  // apart), and a large face by more than the distance tolerance (the sculpted box's sides, in two
  // planes 1° apart), but not by an edge. Idealization would make such planes parallel, and so,
  // sharing a border, coplanar.
  const auto border = turns.find({std::min(a, b), std::max(a, b)});
  q.one_surface = q.same_type && alike(fa, fb, angle_tolerance, tolerance, options.radius_tolerance) &&
                  border != turns.end() && border->second <= std::max(inside_turn(a), inside_turn(b));
  q.one_plane = q.one_surface && fa.type == SurfaceType::Plane;
  q.both = concatenate(pa, pb);
  // A small piece joins its neighbour's surface; two small pieces may make a new one.
  Feature merged = q.larger;
  bool ok = false;
  if ((q.same_type || !q.larger_small) && q.larger.type != SurfaceType::Freeform) {
    const SurfaceFit fit = fit_surface(q.larger.type, q.both, options.fit, &q.larger.surface);
    if (fit.valid) {
      merged.set_fit(fit);
      ok = accepted(q, merged);
    }
  }
  // On an exact tessellation, two large pieces of which one is curved may lie on a third surface:
  // the bands of a coarse torus between its parallels are cones or spheres each.
  const bool one_curved = exact && (fa.type != SurfaceType::Plane || fb.type != SurfaceType::Plane) &&
                          fa.type != SurfaceType::Freeform && fb.type != SurfaceType::Freeform;
  if (!ok && ((a_small && b_small) || one_curved || sectors)) ok = identify_union(q, merged);
  const bool halves = std::abs(fa.surface.axis.dot(fb.surface.axis)) > 0.5;
  if (!ok && !exact && q.same_type && fa.type == SurfaceType::Plane && halves) ok = curved_halves(q, merged);
  if (!ok) return {Verdict::kRejected, {0.0, a, b, Feature()}};
  return {Verdict::kMerged, {merged.rms / q.limit, a, b, merged}};
}

// Applies the verdicts: absorbed pieces first, into the largest patches first (a patch that
// absorbs keeps its surface for this call, refitted to all it took), then the merges, cheapest
// first, each patch in one at most. Returns whether any patch changed.
bool apply_verdicts(const std::vector<PatchPoints>& points, const FeatureOptions& options, bool exact, double exact_distance,
                    std::vector<std::pair<int, int>>& absorbed, std::vector<Candidate>& candidates,
                    std::vector<Feature>& features, std::vector<int>& labels, std::set<std::pair<int, int>>& rejected) {
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& x, const Candidate& y) {
    return x.cost != y.cost ? x.cost < y.cost : std::make_pair(x.a, x.b) < std::make_pair(y.a, y.b);
  });
  std::vector<SurfaceType> type_before(features.size());
  for (size_t p = 0; p < features.size(); ++p) type_before[p] = features[p].type;
  std::vector<char> merged(features.size(), 0);
  std::vector<int> into(features.size());
  for (size_t p = 0; p < into.size(); ++p) into[p] = static_cast<int>(p);
  bool any = false;
  std::sort(absorbed.begin(), absorbed.end(), [&](const auto& x, const auto& y) {
    const double wx = points[x.first].weights.sum(), wy = points[y.first].weights.sum();
    return wx != wy ? wx > wy : x < y;
  });
  std::vector<char> absorbing(features.size(), 0);
  std::map<int, PatchPoints> grown;  // the points of each absorbing patch and its pieces
  for (const auto& [large, piece] : absorbed) {
    if (merged[piece] || absorbing[piece] || merged[large]) continue;
    merged[piece] = absorbing[large] = 1;
    into[piece] = large;
    const auto it = grown.find(large);
    grown[large] = concatenate(it == grown.end() ? points[large] : it->second, points[piece]);
    any = true;
  }
  // The surface refitted to all of them, starting from the one that explained them.
  for (const auto& [large, data] : grown) {
    Feature& f = features[large];
    const SurfaceFit fit = fit_surface(f.type, data, options.fit, &f.surface);
    if (fit.valid && fit.rms <= f.rms + exact_distance) {
      const int id = f.id;
      f.set_fit(fit);
      f.id = id;
    }
  }
  for (const Candidate& c : candidates) {
    if (merged[c.a] || merged[c.b] || absorbing[c.a] || absorbing[c.b]) continue;
    merged[c.a] = merged[c.b] = 1;
    into[c.b] = c.a;
    const int id = features[c.a].id;
    features[c.a] = c.feature;
    features[c.a].id = id;
    any = true;
  }
  for (size_t p = 0; p < absorbing.size(); ++p) merged[p] |= absorbing[p];
  for (int& l : labels)
    if (l >= 0) l = into[l];
  // Pairs with a grown patch are open again, but on an exact tessellation not those of a patch that
  // had the points to fix its surface and kept its type: a surface of that type that explains the
  // grown patch and a neighbour exactly explains the patch as it was and that neighbour, which none
  // did. (Reopening them re-judged every neighbour of a surface that takes its fragments one per
  // call. A patch that changed type may now be explained with a neighbour by a third surface: the
  // bands of a coarse torus.)
  std::vector<char> reopen(merged);
  if (exact)
    for (size_t p = 0; p < reopen.size(); ++p)
      if (into[p] == static_cast<int>(p) && points[p].points.rows() >= kInteriorPoints &&
          features[p].type == type_before[p])
        reopen[p] = 0;
  for (auto it = rejected.begin(); it != rejected.end();)
    it = reopen[it->first] || reopen[it->second] ? rejected.erase(it) : std::next(it);
  return any;
}

}  // namespace

bool merge_patches(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<PatchPoints>& points,
                   const std::function<Feature(const PatchPoints&, const PatchCurvature&)>& identify_points,
                   const FeatureOptions& options, double tolerance, bool exact, double exact_distance, double noise,
                   std::vector<Feature>& features, std::vector<int>& labels, std::set<std::pair<int, int>>& rejected,
                   const ProgressSpan& progress) {
  const std::map<std::pair<int, int>, double> turns = boundary_turns(mesh, topology, labels, true);
  const PairJudge judge{mesh, topology, points, identify_points, options, tolerance, exact, exact_distance, noise,
                        features, labels, turns, options.normal_floor_degrees * M_PI / 180.0,
                        options.angle_tolerance_degrees * M_PI / 180.0};
  // Adjacent pairs, on an exact tessellation not across a crease: sharper than kLargestFacetTurn, and
  // than a quarter more than the sharpest turn inside the larger patch, which on the saddle of a
  // coarse torus exceeds it (the CAD tessellations of the benchmark: up to 54° inside tori, 22°
  // inside any other face).
  std::vector<std::pair<int, int>> pairs;
  for (const auto& [pair, turn] : turns) {
    if (pair.first == pair.second) continue;
    const int larger = points[pair.first].weights.sum() >= points[pair.second].weights.sum() ? pair.first : pair.second;
    if (!exact || turn <= std::max(kLargestFacetTurn, 1.25 * judge.inside_turn(larger))) pairs.push_back(pair);
  }
  // Each pair is judged on its own: on two threads, the verdicts then taken in the pairs' order.
  std::vector<Judgement> judgements(pairs.size());
  std::vector<int> order(pairs.size());
  std::iota(order.begin(), order.end(), 0);
  on_two_threads(order, [&](int i) { judgements[i] = judge.judge(pairs[i].first, pairs[i].second, rejected); },
                 progress);
  std::vector<Candidate> candidates;
  std::vector<std::pair<int, int>> absorbed;  // (large, piece): the large patch's surface explains the piece
  for (Judgement& j : judgements) {
    if (j.verdict == Verdict::kAbsorbed) absorbed.push_back({j.candidate.a, j.candidate.b});
    if (j.verdict == Verdict::kMerged) candidates.push_back(std::move(j.candidate));
    if (j.verdict == Verdict::kRejected) rejected.insert({j.candidate.a, j.candidate.b});
  }
  return apply_verdicts(points, options, exact, exact_distance, absorbed, candidates, features, labels, rejected);
}

// Merges patches that one surface fits together, pass by pass until none merges. On an exact
// tessellation, when no pair merges any more, the small pieces left are tried as surfaces together,
// absorbed by a neighbour, or shattered into facets (exact_fragments.h).
void merge_stage(FeatureState& s) {
  if (s.rimless) s.points = patch_points(s.mesh, s.layer.labels, s.patches);  // what merging sees: the whole rim
  const auto identify_points = [&](const PatchPoints& pp, const PatchCurvature& c) { return s.identify_points(pp, c); };
  std::set<std::pair<int, int>> rejected;
  // Later passes refit fewer open pairs, and most runs stop early: each pass takes a third of
  // what is left of the span.
  const ProgressSpan merge = s.progress.sub("merge", 0.5, 0.87);
  double merged_so_far = 0.0;
  // Every merge removes a patch, so on an exact tessellation merging runs until nothing fits together.
  const int merge_passes = s.exact_mesh ? s.patches : s.options.merge_passes;
  int fragment_rounds = 3;
  bool shattered = false;
  for (int pass = 0; pass < merge_passes; ++pass) {
    const double share = (1.0 - merged_so_far) / 3.0;
    const ProgressSpan this_pass = merge.sub(merged_so_far, merged_so_far + share);
    merged_so_far += share;
    bool merged = merge_patches(s.mesh, s.topology, s.points, identify_points, s.options, s.layer.distance_tolerance,
                                s.exact_mesh, s.exact_distance, s.noise, s.layer.features, s.layer.labels, rejected,
                                this_pass.sub(0.0, 0.9));
    // When no pair merges any more, the small pieces left may still make surfaces together (tried
    // a few times: each time merging may grow the surfaces next to them).
    if (!merged && s.exact_mesh && fragment_rounds-- > 0)
      merged = merge_fragments(s.mesh, s.topology, s.points, s.options, s.exact_distance, s.layer.features,
                               s.layer.labels) ||
               absorb_fragments(s.mesh, s.topology, s.points, s.layer.distance_tolerance, s.layer.features,
                                s.layer.labels);
    // Once, when nothing else places them, the pieces left fall apart into facets (and the fragment
    // passes get their rounds again).
    if (!merged && s.exact_mesh && !shattered) {
      shattered = merged = shatter_fragments(s.mesh, s.points, s.options, s.layer.features, s.layer.labels);
      fragment_rounds = 3;
    }
    if (!merged) break;
    this_pass.step(0.9);
    s.points = patch_points(s.mesh, s.layer.labels, s.patches);
  }
  merge.step(1.0);
}

}  // namespace idealize
