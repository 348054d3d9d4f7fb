// Splitting what no surface fits: into planar regions and grown surfaces, and undoing the splits of
// an exact tessellation that found nothing exact.
#include "features/split.h"

#include "core/parallel.h"
#include "features/identify.h"
#include "features/pipeline.h"

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

namespace {

// State of each face of a patch being split: not in the patch, not yet reached, grown into a region
// that turned out too small (it goes to the remainder), in a kept region, or gathered into a
// remainder component.
enum FaceState : char { kOutside, kUnvisited, kGrown, kKept, kRemainder };

// The faces of `patch` that no kept region took (state kUnvisited or kGrown), in connected
// components: a component too small to be a face of its own joins the kept region it borders most,
// the others become patches, the first of them keeping the id `patch` when `patch_free`. `faces`
// orders the seeds. Returns the next free id.
int label_remainder(const MeshTopology& topology, const std::vector<int>& faces, int patch, bool patch_free,
                    std::vector<char>& state, std::vector<int>& labels, int next_id, const ProgressSpan& progress) {
  long long visited = 0;
  for (int seed : faces) {
    if (state[seed] != kUnvisited && state[seed] != kGrown) continue;
    std::vector<int> component{seed};
    state[seed] = kRemainder;
    std::vector<std::pair<int, int>> borders;  // (region id, shared edges)
    for (size_t head = 0; head < component.size(); ++head) {
      progress.poll(++visited, 1 << 12);
      const int f = component[head];
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        if (g < 0) continue;
        if (state[g] == kKept) {
          auto it = std::find_if(borders.begin(), borders.end(), [&](const auto& b) { return b.first == labels[g]; });
          if (it == borders.end()) borders.emplace_back(labels[g], 1);
          else ++it->second;
        } else if (state[g] == kUnvisited || state[g] == kGrown) {
          state[g] = kRemainder;
          component.push_back(g);
        }
      }
    }
    int id;
    if (static_cast<int>(component.size()) < kInteriorPoints && !borders.empty()) {
      id = std::max_element(borders.begin(), borders.end(), [](const auto& x, const auto& y) {
             return x.second != y.second ? x.second < y.second : x.first > y.first;
           })->first;
    } else {
      id = patch_free ? patch : next_id++;
      patch_free = false;
    }
    for (int f : component) labels[f] = id;
  }
  return next_id;
}

}  // namespace

int split_patch(const TriangleMesh& mesh, const MeshTopology& topology, const Eigen::VectorXd& area, int patch,
                double noise, double normal_noise, int min_region_faces, std::vector<int>& labels, int next_id,
                const ProgressSpan& progress) {
  std::vector<int> faces;
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (labels[f] == patch) faces.push_back(f);
  std::stable_sort(faces.begin(), faces.end(), [&](int x, int y) { return area[x] > area[y]; });
  std::vector<char> open(mesh.num_faces(), kOutside);
  for (int f : faces) open[f] = kUnvisited;
  const double cos_limit = std::cos(std::min(3.0 * normal_noise, 0.5 * M_PI));
  bool first = true;
  long long visited = 0;  // faces taken from the queues: polled every few thousand
  for (int seed : faces) {
    if (open[seed] != kUnvisited) continue;
    Surface plane;
    plane.type = SurfaceType::Plane;
    plane.axis = face_normal(mesh, seed);
    plane.point = face_centroid(mesh, seed);
    std::vector<int> region{seed}, queue{seed};
    open[seed] = kGrown;
    size_t fitted = 1;
    Eigen::Matrix3d moment = Eigen::Matrix3d::Zero();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double weight = 0.0;
    auto accumulate = [&](int f) {
      for (int c = 0; c < 3; ++c) {
        const Eigen::Vector3d v = mesh.V.row(mesh.F(f, c));
        moment += area[f] * v * v.transpose();
        sum += area[f] * v;
        weight += area[f];
      }
    };
    accumulate(seed);
    for (size_t head = 0; head < queue.size(); ++head) {
      progress.poll(++visited, 1 << 12);
      const int f = queue[head];
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        if (g < 0 || open[g] != kUnvisited || std::abs(face_normal(mesh, g).dot(plane.axis)) < cos_limit) continue;
        bool near = true;
        for (int k = 0; k < 3 && near; ++k)
          near = std::abs(signed_distance(plane, mesh.V.row(mesh.F(g, k)).transpose())) <= 3.0 * noise;
        if (!near) continue;
        open[g] = kGrown;
        region.push_back(g);
        queue.push_back(g);
        accumulate(g);
        if (region.size() >= 2 * fitted) {  // refit the plane as the region doubles
          const Eigen::Vector3d centre = sum / weight;
          const Eigen::Matrix3d covariance = moment / weight - centre * centre.transpose();
          Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
          Eigen::Vector3d axis = solver.eigenvectors().col(0);
          plane.axis = axis.dot(plane.axis) < 0.0 ? Eigen::Vector3d(-axis) : axis;
          plane.point = centre;
          fitted = region.size();
        }
      }
    }
    if (static_cast<int>(region.size()) < min_region_faces) continue;  // stays open: remainder
    const int id = first ? patch : next_id++;
    first = false;
    for (int f : region) labels[f] = id;
    for (int f : region) open[f] = kKept;
  }
  return label_remainder(topology, faces, patch, first, open, labels, next_id, progress);
}

namespace {

// How far `surface` bends away from the plane of `data` across its points: the spread of its
// distances from their projections on that plane (zero for a plane).
double bend(const Surface& surface, const FitData& data) {
  const SurfaceFit plane = fit_surface(SurfaceType::Plane, data);
  if (!plane.valid || surface.type == SurfaceType::Plane) return 0.0;
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (Eigen::Index i = 0; i < data.points.rows(); ++i) {
    const Eigen::Vector3d p = data.points.row(i).transpose();
    const double d = signed_distance(surface, p - signed_distance(plane.surface, p) * plane.surface.axis);
    low = std::min(low, d);
    high = std::max(high, d);
  }
  return high - low;
}

}  // namespace

namespace {

// A region grown in a patch as a surface of another type than its disc's (a torus).
struct Grown {
  int id;
  std::vector<int> faces;
  Feature feature;
};

// What the passes of split_into_surfaces share: the patch, the thresholds, the labels being
// written, and per-face scratch.
struct SurfaceGrower {
  const TriangleMesh& mesh;
  const MeshTopology& topology;
  const int patch;
  const double noise, normal_noise, fits_below;
  const int min_region_faces;
  const std::function<Feature(const PatchPoints&)>& identify_points;
  const FitOptions& fit_options;
  std::vector<int>& labels;
  int next_id;
  const ProgressSpan& progress;

  std::vector<int> faces;  // of the patch
  std::vector<int> seeds;  // its faces, deepest (most edge steps from its rim) first, ties by index
  std::vector<char> tried, in_region;
  std::vector<int> slot;
  long long visited = 0;
  std::vector<Grown> tori;  // the regions that grew on as tori

  // The faces of the patch and the seeds (multi-source breadth-first search from its rim).
  void order_seeds() {
    std::vector<int> depth(mesh.num_faces(), -1), queue;
    for (int f = 0; f < mesh.num_faces(); ++f) {
      if (labels[f] != patch) continue;
      faces.push_back(f);
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        if (g < 0 || labels[g] != patch) {
          depth[f] = 0;
          queue.push_back(f);
          break;
        }
      }
    }
    for (size_t head = 0; head < queue.size(); ++head)
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(queue[head], c);
        if (g >= 0 && labels[g] == patch && depth[g] < 0) {
          depth[g] = depth[queue[head]] + 1;
          queue.push_back(g);
        }
      }
    seeds = queue;
    std::stable_sort(seeds.begin(), seeds.end(),
                     [&](int x, int y) { return depth[x] != depth[y] ? depth[x] > depth[y] : x < y; });
  }

  FitData all_points(const std::vector<int>& region_faces) {
    return face_points(mesh, region_faces.data(), static_cast<int>(region_faces.size()), slot, [](int) { return false; });
  }

  // The disc: the nearest `size` faces of the patch from `seed` that no region took.
  std::vector<int> disc(int seed, int size) {
    std::vector<int> region{seed};
    in_region[seed] = 1;
    for (size_t head = 0; head < region.size() && static_cast<int>(region.size()) < size; ++head)
      for (int c = 0; c < 3 && static_cast<int>(region.size()) < size; ++c) {
        const int g = topology.face_neighbor(region[head], c);
        if (g >= 0 && labels[g] == patch && !in_region[g]) {
          in_region[g] = 1;
          region.push_back(g);
        }
      }
    for (int f : region) in_region[f] = 0;
    return region;
  }

  bool fits(const Feature& f) const { return f.type != SurfaceType::Freeform && f.rms <= fits_below; }

  void grow(std::vector<int> region, Feature feature, SurfaceType disc_type);
  void seed_pass();
};

// One region growing from its disc as a surface.
struct Growth {
  SurfaceGrower& g;
  std::vector<int>& region;
  Feature& feature;
  size_t fitted;
  double disc_rms = 0.0;
  Feature fitting;
  size_t fitting_size = 0;
  bool overgrown = false;

  bool explains(int f) const {
    return face_misfit(g.mesh, f, feature.surface, 3.0 * std::max(g.noise, feature.spread),
                       3.0 * std::max(g.normal_noise, feature.normal_spread)) <= 1.0;
  }

  // A refit that no longer fits (the region crept over a neighbouring surface that it explains
  // near their tangent border, and the refit bent towards it) ends growth at the last region
  // that fitted.
  void refit() {
    const SurfaceFit fit = fit_surface(feature.type, g.all_points(region), g.fit_options, &feature.surface);
    if (fit.valid) feature.set_fit(fit);
    fitted = region.size();
    overgrown = !g.fits(feature) && feature.rms > disc_rms + g.noise;
    if (overgrown) return;
    fitting = feature;
    fitting_size = region.size();
  }

  // A cylinder grown on a sector of a tube's bend (a torus whose tube it approximates, the
  // histogram having cut the bend up) stops, or overgrows, where the bend turns away from it.
  // Where the region together with as many faces again beyond it fits no cylinder as well as its
  // disc did, but a ring torus bending across the cylinder's axis (not a barrel about it) does, it
  // grows on as that torus.
  bool generalize() {
    if (feature.type != SurfaceType::Cylinder) return false;
    std::vector<int> wider = region;
    for (size_t head = 0; head < wider.size() && wider.size() < 2 * region.size(); ++head)
      for (int c = 0; c < 3; ++c) {
        const int n = g.topology.face_neighbor(wider[head], c);
        if (n >= 0 && g.labels[n] == g.patch && !g.in_region[n]) {
          g.in_region[n] = 1;
          wider.push_back(n);
        }
      }
    for (size_t i = region.size(); i < wider.size(); ++i) g.in_region[wider[i]] = 0;
    const FitData wider_points = g.all_points(wider);
    const double as_well = std::min(g.fits_below, disc_rms + g.noise);
    const SurfaceFit straight = fit_surface(SurfaceType::Cylinder, wider_points, g.fit_options, &feature.surface);
    if (straight.valid && straight.rms <= disc_rms + g.noise) return false;
    // Or a cone where it fits better than the torus: a cylinder grown on a slender cone tilts by
    // the half-angle and takes half of it, its axis along the cone's generators there (turned from
    // the cone's by up to twice the half-angle and 45°, not across a tube's bend that a flat cone fits).
    const SurfaceFit torus = fit_surface(SurfaceType::Torus, wider_points, g.fit_options);
    const SurfaceFit cone = fit_surface(SurfaceType::Cone, wider_points, g.fit_options);
    const bool torus_fits = torus.valid && torus.rms <= as_well && torus.surface.radius >= torus.surface.minor &&
                            std::abs(torus.surface.axis.dot(feature.surface.axis)) <= std::sqrt(0.5);
    const bool cone_fits = cone.valid && cone.rms <= as_well &&
                           std::abs(cone.surface.axis.dot(feature.surface.axis)) >=
                               std::max(std::sqrt(0.5), std::cos(2.0 * cone.surface.half_angle));
    if (!torus_fits && !cone_fits) return false;
    const SurfaceFit& bent = cone_fits && (!torus_fits || cone.rms < torus.rms) ? cone : torus;
    feature.set_fit(bent);
    fitting = feature;
    fitted = fitting_size = region.size();
    overgrown = false;
    return true;
  }
};

// Grows `region` (faces of the patch) as `feature`, fitted to a disc as a `disc_type`.
void SurfaceGrower::grow(std::vector<int> region, Feature feature, SurfaceType disc_type) {
  for (int f : region) tried[f] = in_region[f] = 1;
  Growth growth{*this, region, feature, region.size(), 0.0, Feature(), 0, false};
  // The disc's faces that the surface does not explain leave it; the rest grows.
  for (int f : region) in_region[f] = growth.explains(f);
  region.erase(std::remove_if(region.begin(), region.end(), [&](int f) { return !in_region[f]; }), region.end());
  growth.disc_rms = feature.rms;
  growth.fitting = feature;
  growth.fitting_size = region.size();
  // When growth stops, the surface refitted to all it took may explain more (a disc across a
  // narrow fillet fixes its radius only roughly): growth resumes while refits add to it.
  for (bool growing = true; growing;) {
    for (size_t head = 0; head < region.size() && !growth.overgrown; ++head) {
      progress.poll(++visited, 1 << 12);
      for (int c = 0; c < 3 && !growth.overgrown; ++c) {
        const int g = topology.face_neighbor(region[head], c);
        if (g < 0 || labels[g] != patch || in_region[g] || !growth.explains(g)) continue;
        in_region[g] = 1;
        region.push_back(g);
        if (region.size() >= 2 * growth.fitted) growth.refit();  // refit as the region doubles
      }
    }
    if (!growth.overgrown && region.size() > growth.fitted + growth.fitted / 8) {  // (bounded rounds: each grows it by an eighth)
      growth.refit();
      continue;
    }
    growing = growth.generalize();
  }
  if (growth.overgrown) {  // (breadth-first: the first faces of the region are connected)
    for (size_t i = growth.fitting_size; i < region.size(); ++i) in_region[region[i]] = 0;
    region.resize(growth.fitting_size);
    feature = growth.fitting;
  }
  for (int f : region) in_region[f] = 0;
  if (static_cast<int>(region.size()) < min_region_faces) return;
  for (int f : region) labels[f] = next_id;
  if (feature.type != disc_type) tori.push_back({next_id, region, feature});
  ++next_id;
}

// Grows a surface from every seed that no region took and whose disc one surface fits.
void SurfaceGrower::seed_pass() {
  const int disc_faces = 2 * kInteriorPoints;
  for (int seed : seeds) {
    if (labels[seed] != patch || tried[seed]) continue;
    std::vector<int> region = disc(seed, disc_faces);
    const FitData disc_points = all_points(region);
    Feature feature;
    if (static_cast<int>(region.size()) == disc_faces) feature = identify_points(disc_points);
    if (static_cast<int>(region.size()) < disc_faces || !fits(feature)) {
      for (int f : region) tried[f] = 1;
      continue;
    }
    // Across a disc on a narrow fillet the surface may bend by less than the noise: the fit is then
    // any surface of little curvature (a cylinder of a hundred times the radius, which grows along
    // the fillet as a flat strip). A larger disc replaces it if its surface fits it and bends by
    // more than the noise; the disc doubles while it still fits.
    const bool flat = bend(feature.surface, disc_points) < noise;
    for (int size = 2 * disc_faces; flat && size <= static_cast<int>(faces.size()); size *= 2) {
      std::vector<int> larger = disc(seed, size);
      const FitData larger_points = all_points(larger);
      const Feature wider = identify_points(larger_points);
      if (!fits(wider) || wider.rms > std::max(feature.rms, noise)) break;  // it reached another surface
      if (bend(wider.surface, larger_points) < noise) continue;
      region = std::move(larger);
      feature = wider;
      break;
    }
    grow(std::move(region), feature, feature.type);
  }
}

}  // namespace

int split_into_surfaces(const TriangleMesh& mesh, const MeshTopology& topology, int patch, double noise,
                        double normal_noise, double fits_below, int min_region_faces,
                        const std::function<Feature(const PatchPoints&)>& identify_points, const FitOptions& fit_options,
                        std::vector<int>& labels, int next_id, std::map<int, Surface>& generalized,
                        const ProgressSpan& progress) {
  SurfaceGrower g{mesh, topology, patch, noise, normal_noise, fits_below, min_region_faces, identify_points,
                  fit_options, labels, next_id, progress, {}, {}, std::vector<char>(mesh.num_faces(), 0),
                  std::vector<char>(mesh.num_faces(), 0), std::vector<int>(mesh.num_vertices(), -1), 0, {}};
  g.order_seeds();
  const int first_id = next_id;
  // A torus found late grows over what the cylinders grown before it left: once one did, the
  // patch is split again with the tori first.
  std::vector<int> first_labels;  // of the faces, after the first pass
  std::vector<Grown> first_tori;
  int first_next = g.next_id;
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1) {
      if (g.tori.empty()) break;
      first_next = g.next_id;
      first_tori = std::move(g.tori);
      g.tori.clear();
      for (int f : g.faces) {
        first_labels.push_back(labels[f]);
        labels[f] = patch;
      }
      std::fill(g.tried.begin(), g.tried.end(), 0);
      g.next_id = first_id;
      for (const Grown& torus : first_tori) g.grow(torus.faces, torus.feature, SurfaceType::Cylinder);
    }
    g.seed_pass();
  }
  const std::vector<int>& faces = g.faces;
  if (!first_labels.empty()) {
    // The second pass stands where it explains the patch with no more regions and leaves no more of
    // its faces to the remainder (a round's torus grown first takes the sectors that cylinders had
    // cut off the plane beside it).
    auto left = [&] { return std::count_if(faces.begin(), faces.end(), [&](int f) { return labels[f] == patch; }); };
    if (g.next_id > first_next || left() > std::count(first_labels.begin(), first_labels.end(), patch)) {
      for (size_t i = 0; i < faces.size(); ++i) labels[faces[i]] = first_labels[i];
      g.tori = std::move(first_tori);
      g.next_id = first_next;
    }
  }
  for (const Grown& torus : g.tori) generalized[torus.id] = torus.feature.surface;
  if (g.next_id == first_id) return g.next_id;  // nothing split off: the patch stays whole
  std::vector<char> state(mesh.num_faces(), kOutside);
  for (int f : faces) state[f] = labels[f] == patch ? kUnvisited : kKept;
  return label_remainder(topology, faces, patch, true, state, labels, g.next_id, progress);
}

void undo_inexact_splits(const TriangleMesh& mesh, const Eigen::VectorXd& area, const std::vector<int>& original,
                         const std::vector<char>& was_split, double exact,
                         const std::function<Feature(const PatchPoints&, const PatchCurvature&)>& identify_points,
                         const std::vector<PatchCurvature>& curvature, std::vector<Feature>& features,
                         std::vector<int>& labels) {
  std::vector<int> triangles(features.size(), 0);
  for (int l : labels)
    if (l >= 0) ++triangles[l];
  std::vector<double> total(was_split.size(), 0.0), fragmented(was_split.size(), 0.0);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const int o = original[f], l = labels[f];
    if (o < 0 || was_split[o] != 1 || l < 0) continue;
    total[o] += area[f];
    if (features[l].type == SurfaceType::Freeform || features[l].rms > exact || triangles[l] == 1) fragmented[o] += area[f];
  }
  std::vector<char> undo(was_split.size(), 0);
  bool any = false;
  for (size_t o = 0; o < was_split.size(); ++o) any |= undo[o] = was_split[o] == 1 && fragmented[o] > 0.5 * total[o];
  if (!any) return;
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (original[f] >= 0 && undo[original[f]]) labels[f] = original[f];
  const std::vector<PatchPoints> whole = patch_points(mesh, labels, static_cast<int>(features.size()));
  for (size_t o = 0; o < undo.size(); ++o)
    if (undo[o]) {
      const int id = features[o].id;
      features[o] = identify_points(whole[o], curvature[o]);
      features[o].id = id;
    }
}

namespace {

// What a split of the badly fitting patches shares: the thresholds above which a patch fits badly,
// and the regions that grew on as tori.
struct Splitting {
  FeatureState& s;
  double split_above = 0.0;          // RMS distance above which a surface does not fit
  double split_normals_above = 0.0;  // RMS normal angle above which it does not (exact meshes)
  std::map<int, Surface> generalized;  // regions that grew on as tori (id -> torus)

  bool badly_fitting(const Feature& f) const {
    return f.type == SurfaceType::Freeform || f.rms > split_above || f.normal_rms > split_normals_above ||
           (s.exact_mesh && f.max_error > split_above);
  }

  // Grows the surfaces that fit discs of patch p. A patch that the histograms call curved has no
  // planar regions: across a disc, the sag of a large fillet hides within the distance tolerance.
  int grow_surfaces(int p, std::vector<int>& into, int first_id, std::map<int, Surface>& tori,
                    const ProgressSpan& span) const {
    const bool curved = curvature_type(s.curvature[p], s.zero_mean_curvature) != SurfaceType::Plane;
    return split_into_surfaces(
        s.mesh, s.topology, p, s.noise, s.normal_noise, split_above, 2 * kInteriorPoints,
        [&](const PatchPoints& pp) {
          return identify(pp, s.curvature[p], s.zero_mean_curvature, s.options, s.layer.distance_tolerance, curved);
        },
        s.options.fit, into, first_id, tori, span);
  }

  // Identification takes the simplest surface within the tolerance, which on a sector of a
  // tube's bend is a cylinder: a region that grew as a torus (above) stays one where the torus
  // still fits it as a split requires.
  void keep_generalized() {
    for (const auto& [id, surface] : generalized) {
      Feature& f = s.layer.features[id];
      if (f.type != SurfaceType::Cylinder) continue;
      const SurfaceFit fit = fit_surface(surface.type, s.points[id], s.options.fit, &surface);
      if (fit.valid && fit.rms <= split_above) f.set_fit(fit);
    }
  }
};

// The farthest vertex of each patch's triangles from its surface, rim included (infinite for a
// freeform patch).
std::vector<double> farthest_vertices(const FeatureState& s) {
  std::vector<double> farthest(s.layer.features.size(), 0.0);
  for (size_t p = 0; p < farthest.size(); ++p)
    if (s.layer.features[p].type == SurfaceType::Freeform) farthest[p] = std::numeric_limits<double>::infinity();
  for (int f = 0; f < s.mesh.num_faces(); ++f) {
    const int p = s.layer.labels[f];
    if (p < 0 || std::isinf(farthest[p])) continue;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d v = s.mesh.V.row(s.mesh.F(f, k));
      farthest[p] = std::max(farthest[p], std::abs(signed_distance(s.layer.features[p].surface, v)));
    }
  }
  return farthest;
}

// Whether the mesh samples its surface uniformly, as remeshers and scanners' reconstructions do:
// the 10th and 90th percentiles of its edge lengths within a factor of two. An isotropic remesher
// keeps its edges between 4/5 and 4/3 of its target (a ratio of 5/3); a CAD tessellator's edges
// follow the sizes and curvatures of the part's faces (measured: 3.8 to 340 on the CAD exports of
// the test data's 61 parts, 1.1 to 1.7 on its remeshed real meshes).
bool uniformly_sampled(const TriangleMesh& mesh) {
  std::vector<double> length;
  length.reserve(3 * static_cast<size_t>(mesh.num_faces()));
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) length.push_back((mesh.V.row(mesh.F(f, k)) - mesh.V.row(mesh.F(f, (k + 1) % 3))).norm());
  if (length.empty()) return false;
  const size_t low = length.size() / 10, high = length.size() - 1 - length.size() / 10;
  std::nth_element(length.begin(), length.begin() + low, length.end());
  const double p10 = length[low];
  std::nth_element(length.begin(), length.begin() + high, length.end());
  return length[high] < 2.0 * p10;
}

// The value below which `share` of the weight lies: (value, weight) pairs, sorted here.
double weighted_quantile(std::vector<std::pair<double, double>> values, double share) {
  std::sort(values.begin(), values.end());
  double total = 0.0;
  for (const auto& v : values) total += v.second;
  double below = 0.0;
  for (const auto& [value, weight] : values)
    if ((below += weight) >= share * total) return value;
  return values.empty() ? 0.0 : values.back().first;
}

// The mesh's kind and noise from its patches' fits, each weighed by its evidence: its points beyond
// the surface's parameters (a patch of as many points as parameters fits any noise exactly).
//
// A mesh is noiseless when the best-fitting tenth of the evidence fits to a hundredth of the
// tolerance. On a noisy or sculpted mesh no patch of many points fits that closely; on a CAD
// export, or a remesh whose vertices were projected onto the part, the patches that cover one face
// do, however many others the segmentation joined across edges. Measured on the test data's 61
// parts and 9 real meshes, the share of the evidence in such patches is 0 on every scan-like mesh
// and at most 0.07 on the sculpted ones (whose bumps leave some faces untouched), against 0.11 to
// 1 on the noiseless ones: a tenth lies between the two.
//
// An exact tessellation is a CAD export: its triangles lie on their faces, so that its patches fit
// to a hundredth of the tolerance with their rims too, unless the segmentation joined faces of the
// coarse, uneven tessellation. A remeshed surface whose vertices were projected onto the part fits
// as closely inside its patches, but its uniform triangles straddle the part's edges, and the
// typical patch's rim leaves its surface by a good part of an edge length: it is a measured surface
// without noise. Returns false when no patch has a surface (nothing to measure).
bool decide_mesh_kind(FeatureState& s) {
  constexpr double kBestShare = 0.1;  // see above: between 0.07 (sculpted) and 0.11 (noiseless)
  std::vector<std::pair<double, double>> weighed;  // (spread, evidence)
  std::vector<double> rms, normal_rms;
  for (size_t p = 0; p < s.layer.features.size(); ++p)
    if (const Feature& f = s.layer.features[p]; f.type != SurfaceType::Freeform) {
      const double evidence = std::max(0.0, static_cast<double>(s.points[p].points.rows()) - parameter_count(f.type));
      weighed.push_back({f.spread, evidence});
      rms.push_back(f.spread);
      normal_rms.push_back(f.normal_spread);
    }
  if (rms.empty()) return false;
  s.noiseless = weighted_quantile(weighed, kBestShare) < kExactFraction * s.layer.distance_tolerance;
  // The noise is what the typical patch shows (the lower median: of two patches, the one that fits
  // shows the noise).
  const size_t middle = (rms.size() - 1) / 2;
  std::nth_element(rms.begin(), rms.begin() + middle, rms.end());
  std::nth_element(normal_rms.begin(), normal_rms.begin() + middle, normal_rms.end());
  s.noise = rms[middle] + s.floor;
  s.normal_noise += normal_rms[middle];
  if (s.noiseless && !s.options.measured) {
    std::vector<double> farthest;
    const std::vector<double> farthest_vertex = farthest_vertices(s);
    for (size_t p = 0; p < s.layer.features.size(); ++p)
      if (s.layer.features[p].type != SurfaceType::Freeform) farthest.push_back(farthest_vertex[p]);
    std::nth_element(farthest.begin(), farthest.begin() + middle, farthest.end());
    s.exact_mesh = farthest[middle] < s.exact_distance || !uniformly_sampled(s.mesh);
  }
  return true;
}

// A dome revolved from an arc centred beyond its axis (a lemon) fits none of the surfaces that
// identification seeds from its points; on an exact tessellation its torus may be a lemon.
void try_lemons(Splitting& split) {
  FeatureState& s = split.s;
  for (int p = 0; p < s.num_patches && s.exact_mesh; ++p) {
    if (!split.badly_fitting(s.layer.features[p]) || s.points[p].points.rows() < kInteriorPoints) continue;
    if (const std::optional<SurfaceFit> lemon =
            fit_lemon(s.points[p], s.options.fit, s.layer.distance_tolerance, s.exact_distance)) {
      Feature torus = s.layer.features[p];
      torus.set_fit(*lemon);
      if (!split.badly_fitting(torus)) s.layer.features[p] = torus;
    }
  }
}

// Splits every badly fitting patch of the segmentation. On a noisy mesh, surfaces grow in a large
// patch first (fillets of one radius in a chain); planar regions split the rest. A patch splits by
// its own faces alone (the others' labels only tell them apart): on two threads, each into its
// copy of the labels with new ids from the patch count on (and its patch's faces set back after
// each); the pieces are then numbered on in patch order, as splitting one patch after the other
// numbers them. Returns the next free id.
int split_patches(Splitting& split, const ProgressSpan& span) {
  FeatureState& s = split.s;
  struct Pieces {
    std::vector<std::pair<int, int>> faces;  // (face, its new label)
    int count = 0;                            // new ids
    std::map<int, Surface> tori;              // new id -> torus (generalized)
  };
  const int num_patches = s.num_patches;
  int next_id = num_patches;
  const std::vector<int> first_count = s.triangle_counts();
  std::vector<char> splitting(num_patches, 0);
  for (int p = 0; p < num_patches; ++p)
    if (split.badly_fitting(s.layer.features[p])) {
      splitting[p] = 1;
      s.was_split[p] = s.exact_mesh ? 1 : 2;
    }
  std::vector<Pieces> split_pieces(num_patches);
  std::vector<std::vector<int>> faces_of(num_patches);
  for (int f = 0; f < s.mesh.num_faces(); ++f)
    if (s.layer.labels[f] >= 0 && splitting[s.layer.labels[f]]) faces_of[s.layer.labels[f]].push_back(f);
  const int first_piece_id = next_id;
  const std::vector<int> order = largest_first(s.points, splitting);
  on_two_threads([&](size_t half) {
    std::vector<int> split_labels = s.layer.labels;
    for (size_t k = half; k < order.size(); k += 2) {
      if (half == 0) span.step(static_cast<double>(k) / order.size());
      const int p = order[k];
      int end = first_piece_id;
      if (!s.exact_mesh && first_count[p] >= 4 * kInteriorPoints)
        end = split.grow_surfaces(p, split_labels, first_piece_id, split_pieces[p].tori, ProgressSpan());
      if (end == first_piece_id)
        end = split_patch(s.mesh, s.topology, s.area, p, s.noise, s.normal_noise,
                          s.exact_mesh ? 1 : 2 * kInteriorPoints, split_labels, first_piece_id, ProgressSpan());
      split_pieces[p].count = end - first_piece_id;
      for (int f : faces_of[p]) {
        if (split_labels[f] != p) split_pieces[p].faces.push_back({f, split_labels[f]});
        split_labels[f] = p;
      }
    }
  });
  for (int p = 0; p < num_patches; ++p) {
    const int shift = next_id - first_piece_id;
    for (const auto& [f, id] : split_pieces[p].faces) s.layer.labels[f] = id >= first_piece_id ? id + shift : id;
    for (const auto& [id, torus] : split_pieces[p].tori) split.generalized[id + shift] = torus;
    next_id += split_pieces[p].count;
  }
  return next_id;
}

// Identifies the pieces the split made (ids from the patch count to `next_id`), the freeform
// patches and the badly fitting ones again; `span` is the whole split's.
void identify_pieces(Splitting& split, int next_id, const ProgressSpan& span) {
  FeatureState& s = split.s;
  const int num_patches = s.num_patches;
  std::vector<char> which(next_id, 0);
  for (int l : s.layer.labels)
    if (l >= 0 && l < num_patches && s.layer.features[l].type == SurfaceType::Freeform) which[l] = 1;
  for (int p = 0; p < num_patches; ++p)
    if (split.badly_fitting(s.layer.features[p])) which[p] = 1;
  for (int p = num_patches; p < next_id; ++p) which[p] = 1;
  s.curvature.resize(next_id);
  for (int f = 0; f < s.mesh.num_faces(); ++f)  // a split region keeps the curvature of its patch
    if (s.layer.labels[f] >= num_patches) s.curvature[s.layer.labels[f]] = s.patch_curvature[s.segment_labels[f]];
  span.step(0.5);
  s.points = patch_points(s.mesh, s.layer.labels, next_id);
  s.identify_all(s.points, which, span.sub(0.6, 0.8));
  split.keep_generalized();
}

// On a noisy mesh, a large piece that still no surface fits is split by growing surfaces.
void grow_in_large_pieces(Splitting& split, int next_id, const ProgressSpan& span) {
  FeatureState& s = split.s;
  const int pieces = next_id;
  const std::vector<int> count = s.triangle_counts();
  std::vector<char> which(pieces, 0);
  for (int p = 0; p < pieces; ++p) {
    if (count[p] < 4 * kInteriorPoints || !split.badly_fitting(s.layer.features[p])) continue;
    const int first_new = next_id;
    next_id = split.grow_surfaces(p, s.layer.labels, next_id, split.generalized, span.sub(0.0, 0.5));
    s.curvature.resize(next_id, s.curvature[p]);
    which.resize(next_id, 1);
    which[p] = next_id > first_new;
  }
  if (next_id > pieces) {
    s.points = patch_points(s.mesh, s.layer.labels, next_id);
    s.identify_all(s.points, which, span.sub(0.5, 1.0));
    split.keep_generalized();
  }
}

}  // namespace

// Split what no surface fits into planar regions (and, on noisy meshes, the connected rest);
// merging joins pieces again where one surface fits them together. On exact tessellations every
// planar facet is kept as a piece.
void split_badly_fitting(FeatureState& s) {
  const ProgressSpan split = s.progress.sub("split", 0.19, 0.355);
  split.step(0.0);
  if (!decide_mesh_kind(s)) return;
  Splitting splitting{s, 0.0, 0.0, {}};
  // Measured on the benchmark: without the tolerance term, sculpted (undulating) patches split
  // into pieces that do not join again. An exact tessellation does not undulate: what does not
  // fit it exactly is split.
  splitting.split_above =
      s.options.split_ratio * s.noise + (s.exact_mesh ? kExactFraction : 1.0) * s.layer.distance_tolerance;
  // There normals count too: a patch fitted to its interior vertices does not see a whole coarse
  // face whose vertices all lie on its rim (a small CAD cylinder inside a plane's patch). On a
  // noisy mesh, where every face has interior vertices, this would split patches that merely
  // have a rough rim (measured on the benchmark). So does the farthest vertex: a step of two
  // sliver facets beside a plane moves its RMS and its normals' by less than their tiny area.
  splitting.split_normals_above =
      s.exact_mesh ? s.options.split_ratio * s.normal_noise : std::numeric_limits<double>::infinity();
  s.split_above = splitting.split_above;
  try_lemons(splitting);
  const int next_id = split_patches(splitting, split.sub(0.0, 0.5));
  if (next_id > s.num_patches) identify_pieces(splitting, next_id, split);
  if (!s.exact_mesh) grow_in_large_pieces(splitting, next_id, split.sub(0.8, 1.0));
}

}  // namespace idealize
