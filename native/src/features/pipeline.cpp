// The feature pipeline (pipeline.h): the state the stages share, the short stages, and the order.
#include "features/pipeline.h"

#include "features/identify.h"
#include "features/project_vertices.h"
#include "features/tangent_boundaries.h"
#include "core/parallel.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace idealize {

void Feature::set_fit(const SurfaceFit& fit) {
  surface = fit.surface;
  type = fit.surface.type;
  rms = fit.rms;
  max_error = fit.max_error;
  normal_rms = fit.normal_rms;
  spread = fit.spread;
  normal_spread = fit.normal_spread;
}

FeatureState::FeatureState(const TriangleMesh& mesh, const std::vector<int>& labels,
                           const std::vector<PatchCurvature>& patch_curvature,
                           const EffectiveZero& zero_mean_curvature, const FeatureOptions& options)
    : mesh(mesh),
      segment_labels(labels),
      patch_curvature(patch_curvature),
      zero_mean_curvature(zero_mean_curvature),
      options(options),
      // Shares of the whole run, as measured on a scan of a million triangles: refitting after each
      // change of the patches dominates.
      progress(options.progress, "fit"),
      topology(mesh),
      area(face_areas(mesh)),
      num_patches(static_cast<int>(patch_curvature.size())),
      floor(coordinate_floor(mesh)),
      curvature(patch_curvature),
      was_split(num_patches, 0),
      normal_noise(options.normal_floor_degrees * M_PI / 180.0) {
  const double diagonal = bounding_box_diagonal(mesh);
  layer.distance_tolerance = options.distance_tolerance > 0.0 ? options.distance_tolerance : 1e-3 * diagonal;
  layer.angle_tolerance_degrees = options.angle_tolerance_degrees;
  exact_distance = std::max(kExactFraction * layer.distance_tolerance, 2.0 * floor);
  noise = floor;  // until the split stage measures it
  layer.labels = labels;
}

Feature FeatureState::identify_points(const PatchPoints& pp, const PatchCurvature& c) const {
  return identify(pp, c, zero_mean_curvature, options, layer.distance_tolerance);
}

void FeatureState::identify_all(const std::vector<PatchPoints>& patch_points, const std::vector<char>& which,
                                const ProgressSpan& span) {
  // Each patch's fit is its own: on two threads.
  layer.features.resize(patch_points.size());
  on_two_threads(
      largest_first(patch_points, which),
      [&](int p) { layer.features[p] = identify_points(patch_points[p], curvature[p]); }, span);
}

std::vector<int> FeatureState::triangle_counts() const {
  std::vector<int> count(layer.features.size(), 0);
  for (int l : layer.labels)
    if (l >= 0) ++count[l];
  return count;
}

void FeatureState::refit_changed(const std::vector<char>& changed, const ProgressSpan& span) {
  std::vector<char> which = changed;
  for (size_t p = 0; p < which.size(); ++p) which[p] &= layer.features[p].type != SurfaceType::Freeform;
  on_two_threads(
      largest_first(points, which),
      [&](int p) {
        Feature& f = layer.features[p];
        const SurfaceFit fit = fit_surface(f.type, points[p], options.fit, &f.surface);
        if (fit.valid) f.set_fit(fit);
      },
      span);
}

std::vector<FloodSurface> FeatureState::flood_surfaces() const {
  std::vector<FloodSurface> surfaces(layer.features.size());
  for (size_t p = 0; p < surfaces.size(); ++p) {
    const Feature& f = layer.features[p];
    // On a measured surface without noise (a clean remesh) the spreads of the surfaces that fit are
    // next to nothing, and a face that straddles a sharp edge is all but impossible under each: a
    // surface that does not fit its own faces would take them all, in units of its large spread,
    // all along the part's edges. There it keeps its faces and takes none.
    const bool unfit = noiseless && f.rms > split_above;
    surfaces[p].surface = f.type == SurfaceType::Freeform || unfit ? nullptr : &f.surface;
    surfaces[p].distance_unit = std::max(noise, f.spread);
    surfaces[p].angle_unit = std::max(normal_noise, f.normal_spread);
  }
  return surfaces;
}

// On a noisy mesh, a patch that the surfaces around it explain adds nothing but edges: the strip
// of chamfered facets along a sharp edge, fitted by a cylinder of about its width. Before the
// relaxation, which then settles the borders the strips leave, and once more at the end for the
// strips that splitting and merging leave. The changed patches are refitted without their rims,
// as relaxing does.
bool FeatureState::dissolve_strips() {
  if (exact_mesh) return false;
  const std::vector<char> changed = dissolve_explained_patches(mesh, topology, flood_surfaces(), layer.labels, progress);
  if (std::find(changed.begin(), changed.end(), 1) == changed.end()) return false;
  points = patch_points(mesh, layer.labels, patches, 1);
  refit_changed(changed, ProgressSpan());
  return true;
}

namespace {

// Every patch of the segmentation identified.
void fit_patches(FeatureState& s) {
  s.points = patch_points(s.mesh, s.layer.labels, s.num_patches);
  s.identify_all(s.points, std::vector<char>(s.num_patches, 1), s.progress.sub(0.01, 0.06));
}

// On a noisy mesh, the split pieces flood again from their surfaces: greedy growth left borders
// where the first surface to grow stopped (the halves of a narrow fillet on the planes beside it).
// The borders move, then the surfaces are refitted to what they took, before merging joins pieces.
void relax_borders(FeatureState& s) {
  for (int round = 0; round < s.options.relaxation_rounds; ++round) {
    const std::vector<char> changed = flood_labels(s.mesh, s.topology, s.flood_surfaces(), s.options.relaxation_band,
                                                   s.layer.labels, s.progress);
    if (std::find(changed.begin(), changed.end(), 1) == changed.end()) break;
    s.rimless = true;
    // Each border went to the surface that the noise of its faces happened to favour: fitted to
    // them, a fillet's radius drifts from round to round (on the bracket's noisy scan one came
    // out 7 % large), so the refits leave out a ring of faces along every rim.
    s.points = patch_points(s.mesh, s.layer.labels, s.patches, 1);
    s.refit_changed(changed, ProgressSpan());
  }
}

// The graph and the ideal surfaces stay as they are: refitting and idealizing the features whose
// borders moved shifts the radii of a sculpted part's equal fillets apart.
void settle_tangent_borders(FeatureState& s) {
  if (!s.exact_mesh && settle_tangent_boundaries(s.mesh, s.topology, s.layer.features, s.layer.relations, s.layer.labels) > 0)
    count_faces(s.area, s.layer.labels, s.layer.features);
}

void project(FeatureState& s) {
  const ProgressSpan projection = s.progress.sub("projection", 0.99, 1.0);
  project_vertices(s.mesh, s.topology, s.layer.labels, s.layer.features, s.layer.distance_tolerance, s.layer,
                   projection);
  projection.step(1.0);
}

bool always(const FeatureState&) { return true; }
bool noisy(const FeatureState& s) { return !s.exact_mesh; }

struct Stage {
  const char* name;                        // its entry in the layer's timings
  void (*run)(FeatureState&);
  bool (*applies)(const FeatureState&);    // a stage that does not apply is neither run nor timed
};

// The stages in order, with their shares of the progress bar.
const Stage kStages[] = {
    {"fit", fit_patches, always},
    {"reassign", [](FeatureState& s) { reassign_rims(s, s.progress.sub("reassign", 0.06, 0.19)); }, always},
    {"split", split_badly_fitting, always},
    {"reassign_after_split",
     [](FeatureState& s) {
       reassign_rims(s, s.progress.sub("reassign", 0.355, 0.5));
       s.patches = static_cast<int>(s.layer.features.size());
     },
     always},
    {"dissolve", [](FeatureState& s) { s.rimless = s.dissolve_strips(); }, always},
    {"relax", relax_borders, noisy},
    {"merge", merge_stage, always},
    {"reassign_after_merge", [](FeatureState& s) { reassign_rims(s, s.progress.sub("reassign", 0.87, 0.975)); },
     always},
    {"dissolve_after_merge", [](FeatureState& s) { s.dissolve_strips(); }, always},
    {"settle", settle_features, always},
    {"edge_fillets", fit_noisy_edges, noisy},
    {"classify", classify_features, always},
    {"relations", relate_features, always},
    {"idealize", idealize_layer, [](const FeatureState& s) { return s.options.idealize; }},
    {"tangent_boundaries", settle_tangent_borders, always},
    {"projection", project, always},
};

}  // namespace

FeatureLayer identify_features(const TriangleMesh& mesh, const std::vector<int>& labels,
                               const std::vector<PatchCurvature>& patch_curvature,
                               const EffectiveZero& zero_mean_curvature, const FeatureOptions& options) {
  if (static_cast<int>(labels.size()) != mesh.num_faces())
    throw MeshError("the labels do not match the mesh (one label per triangle is needed)");
  const int num_patches = static_cast<int>(patch_curvature.size());
  for (int label : labels)
    if (label >= num_patches) throw MeshError("a triangle label names a patch that does not exist");

  ProgressSpan(options.progress, "fit").step(0.0);  // a cancelled Progress stops here, before any work
  auto start = std::chrono::steady_clock::now();
  FeatureState state(mesh, labels, patch_curvature, zero_mean_curvature, options);
  for (const Stage& stage : kStages) {
    if (!stage.applies(state)) continue;
    stage.run(state);
    const auto now = std::chrono::steady_clock::now();
    state.layer.timings.emplace_back(stage.name, std::chrono::duration<double>(now - start).count());
    start = now;
  }
  state.layer.mesh_kind = state.exact_mesh ? MeshKind::ExactTessellation : MeshKind::MeasuredSurface;
  state.layer.noise = state.noise;
  state.layer.normal_noise = state.normal_noise;
  return std::move(state.layer);
}

}  // namespace idealize
