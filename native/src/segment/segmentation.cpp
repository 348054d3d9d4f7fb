#include "segment/segmentation.h"

#include "prepare/denoising.h"
#include "prepare/mesh_preparation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <queue>

namespace idealize {

namespace {

class StageTimer {
 public:
  explicit StageTimer(std::vector<std::pair<std::string, double>>& timings) : timings_(timings) {}
  void stage(const char* name) {
    const auto now = std::chrono::steady_clock::now();
    timings_.emplace_back(name, std::chrono::duration<double>(now - start_).count());
    start_ = now;
  }

 private:
  std::vector<std::pair<std::string, double>>& timings_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

constexpr int kTransition = -1;

// Vertex classes of pass 1, then of pass 2 (offset so that the two never collide).
constexpr int kSharpConcave = 0;
constexpr int kSharpConvex = 1;
constexpr int kSmoothBase = 2;

// Area-weighted one-ring means of `values`, only among vertices where `active` is set.
Eigen::VectorXd smooth_values(const Eigen::VectorXd& values, const Eigen::VectorXd& area,
                              const std::vector<char>& active, const MeshTopology& topology,
                              int iterations, const ProgressSpan& progress) {
  Eigen::VectorXd current = values, next = values;
  for (int it = 0; it < iterations; ++it) {
    progress.step(static_cast<double>(it) / iterations);
    for (int v = 0; v < current.size(); ++v) {
      if (!active[v]) continue;
      double weight = area[v], sum = area[v] * current[v];
      for (const int* n = topology.vertex_neighbors_begin(v); n != topology.vertex_neighbors_end(v); ++n)
        if (active[*n]) {
          weight += area[*n];
          sum += area[*n] * current[*n];
        }
      next[v] = weight > 0.0 ? sum / weight : current[v];
    }
    current.swap(next);
  }
  return current;
}

// A face takes its vertices' common class, or is a transition.
std::vector<int> face_classes(const MatrixX3i& F, const std::vector<int>& vertex_class) {
  std::vector<int> out(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const int c = vertex_class[F(f, 0)];
    out[f] = (c >= 0 && c == vertex_class[F(f, 1)] && c == vertex_class[F(f, 2)]) ? c : kTransition;
  }
  return out;
}

// A patch none of whose faces has all three vertices inside the patch is at most two faces wide:
// too thin to be a feature at this sampling (a speck of noise inside a transition zone). Such
// patches become transitions, so that thinning can grow the real patches through them.
void dissolve_slivers(const TriangleMesh& mesh, const MeshTopology& topology, std::vector<int>& label,
                      int num_patches) {
  std::vector<char> has_core(num_patches, 0);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const int p = label[f];
    if (p == kTransition || has_core[p]) continue;
    bool core = true;
    for (int c = 0; c < 3 && core; ++c) {
      const int v = mesh.F(f, c);
      for (const int* g = topology.vertex_faces_begin(v); g != topology.vertex_faces_end(v); ++g)
        if (label[*g] != p) {
          core = false;
          break;
        }
    }
    has_core[p] = core;
  }
  for (int& p : label)
    if (p != kTransition && !has_core[p]) p = kTransition;
}

// Transition thinning (thesis 3.2.1.5): patches grow into transition zones as long as a triangle
// touches no other patch, so what remains are one-triangle-wide strips, each of whose triangles
// touches two or more patches. The thesis grows the strip along the highest curvature; here each
// triangle joins in order of how close its curvature is to the patch's mean, which puts the strip
// on the crest of a sharp edge and in the middle of the curvature ramp between tangent faces
// (growing the flattest first would let a plane swallow half of every fillet beside it).
//
// With `fold` set, the strips themselves are then folded into the patches (thesis 4.3, first step
// of part 2): every transition triangle joins an edge-adjacent patch, most similar first, so that
// patches meet along edge polylines.
void grow_patches(const TriangleMesh& mesh, const MeshTopology& topology, const Eigen::VectorXd& curvature,
                  int num_patches, bool fold, std::vector<int>& label, const ProgressSpan& progress) {
  constexpr int kNone = -1, kSeveral = -2;
  auto face_curvature = [&](int f) {
    return (curvature[mesh.F(f, 0)] + curvature[mesh.F(f, 1)] + curvature[mesh.F(f, 2)]) / 3.0;
  };
  std::vector<double> patch_mean(num_patches, 0.0), patch_count(num_patches, 0.0);
  std::vector<int> touching(mesh.num_vertices(), kNone);  // the one patch a vertex touches
  auto touch = [&](int v, int patch) {
    if (touching[v] == kNone) touching[v] = patch;
    else if (touching[v] != patch) touching[v] = kSeveral;
  };
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (label[f] != kTransition) {
      patch_mean[label[f]] += face_curvature(f);
      patch_count[label[f]] += 1.0;
      for (int c = 0; c < 3; ++c) touch(mesh.F(f, c), label[f]);
    }
  for (int p = 0; p < num_patches; ++p)
    if (patch_count[p] > 0.0) patch_mean[p] /= patch_count[p];

  // The patch that face f may join, or kNone.
  auto joinable = [&](int f) {
    if (fold) {  // the edge-adjacent patch of most similar curvature
      int best = kNone;
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        if (g < 0 || label[g] == kTransition) continue;
        if (best == kNone || std::abs(face_curvature(f) - patch_mean[label[g]]) <
                                 std::abs(face_curvature(f) - patch_mean[best]))
          best = label[g];
      }
      return best;
    }
    int patch = kNone;
    for (int c = 0; c < 3; ++c) {
      const int t = touching[mesh.F(f, c)];
      if (t == kSeveral) return kNone;
      if (t == kNone) continue;
      if (patch != kNone && patch != t) return kNone;
      patch = t;
    }
    if (patch == kNone) return kNone;
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g >= 0 && label[g] == patch) return patch;  // joins through an edge, never a lone vertex
    }
    return kNone;
  };

  using Entry = std::pair<double, int>;  // (curvature difference, face): most similar first, ties by index
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  auto push = [&](int f) {
    const int patch = joinable(f);
    if (patch != kNone) queue.emplace(std::abs(face_curvature(f) - patch_mean[patch]), f);
  };
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (label[f] == kTransition) push(f);
  for (long long popped = 0; !queue.empty(); ++popped) {
    progress.poll(popped);
    const int f = queue.top().second;
    queue.pop();
    if (label[f] != kTransition) continue;
    const int patch = joinable(f);
    if (patch == kNone) continue;
    label[f] = patch;
    for (int c = 0; c < 3; ++c) {
      const int v = mesh.F(f, c);
      touch(v, patch);
      for (const int* g = topology.vertex_faces_begin(v); g != topology.vertex_faces_end(v); ++g)
        if (label[*g] == kTransition) push(*g);
    }
  }
}

// Mean incident edge length of every vertex: the local sampling resolution.
Eigen::VectorXd local_edge_length(const TriangleMesh& mesh, const MeshTopology& topology) {
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(mesh.num_vertices());
  Eigen::VectorXi count = Eigen::VectorXi::Zero(mesh.num_vertices());
  for (int e = 0; e < topology.num_edges(); ++e) {
    const auto& ev = topology.edge_vertices(e);
    const double length = (mesh.V.row(ev[0]) - mesh.V.row(ev[1])).norm();
    for (int v : ev) {
      sum[v] += length;
      ++count[v];
    }
  }
  for (int v = 0; v < mesh.num_vertices(); ++v)
    if (count[v] > 0) sum[v] /= count[v];
  return sum;
}

// Vertices all of whose faces have three vertices of the region: the region minus its rim.
std::vector<char> region_interior(const MatrixX3i& F, const std::vector<char>& region) {
  std::vector<char> interior = region;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    if (!region[F(f, 0)] || !region[F(f, 1)] || !region[F(f, 2)])
      for (int c = 0; c < 3; ++c) interior[F(f, c)] = 0;
  return interior;
}

// Drops patches that kept no input face and renumbers the rest in order of first appearance.
int compact_patches(std::vector<int>& labels, std::vector<int>& working_labels, int num_patches) {
  std::vector<int> renumber(num_patches, kTransition);
  int next = 0;
  for (int& p : labels)
    if (p != kTransition) {
      if (renumber[p] == kTransition) renumber[p] = next++;
      p = renumber[p];
    }
  for (int& p : working_labels)
    if (p != kTransition) p = renumber[p];
  return next;
}

}  // namespace

namespace {

// The orientation repair of the prepared mesh (`flipped`, per prepared face) in input terms, for
// the later stages that work on the input's triangles; a duplicate takes the orientation of the
// triangle it repeats.
std::vector<char> flipped_in_input(const TriangleMesh& input, const PreparedMesh& prepared,
                                   const std::vector<char>& flipped) {
  std::vector<char> input_flipped(input.num_faces(), 0);
  for (int f = 0; f < input.num_faces(); ++f) {
    const int w = prepared.input_face[f];
    if (w < 0) continue;
    const int origin = prepared.face_origin[w];
    bool reversed = false;  // f lists the vertices of `origin` in the opposite cyclic order
    if (origin != f) {
      const int k = input.F(f, 0) == input.F(origin, 0) ? 0 : input.F(f, 0) == input.F(origin, 1) ? 1 : 2;
      reversed = input.F(f, 1) != input.F(origin, (k + 1) % 3);
    }
    input_flipped[f] = static_cast<char>(flipped[w] ^ (reversed ? 1 : 0));
  }
  return input_flipped;
}

// Map back: each input face takes the patch covering most of its area (out.labels) and is a
// transition where transitions cover most of it (out.transition); duplicates repeat the label of
// the face they duplicate. `area`: of the working mesh's faces.
void map_back_labels(const TriangleMesh& input, const PreparedMesh& prepared, const Eigen::VectorXd& area,
                     const std::vector<char>& working_transition, Segmentation& out) {
  const TriangleMesh& mesh = out.working.mesh;
  const int nf_input = input.num_faces();
  std::vector<std::vector<std::pair<int, double>>> shares(nf_input);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const int patch = out.working_labels[f];
    if (patch == kTransition) continue;
    auto& s = shares[out.working.face_origin[f]];
    auto it = std::find_if(s.begin(), s.end(), [&](const auto& p) { return p.first == patch; });
    if (it == s.end()) s.emplace_back(patch, area[f]);
    else it->second += area[f];
  }
  out.labels.assign(nf_input, kTransition);
  for (int f = 0; f < nf_input; ++f) {
    double best = 0.0;
    for (const auto& [patch, a] : shares[f])
      if (a > best) {
        best = a;
        out.labels[f] = patch;
      }
  }
  std::vector<double> transition_area(nf_input, 0.0), total_area(nf_input, 0.0);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    total_area[out.working.face_origin[f]] += area[f];
    if (working_transition[f]) transition_area[out.working.face_origin[f]] += area[f];
  }
  out.transition.assign(nf_input, 0);
  for (int f = 0; f < nf_input; ++f) out.transition[f] = transition_area[f] > 0.5 * total_area[f];
  for (int f = 0; f < nf_input; ++f) {
    const int working = prepared.input_face[f];
    if (working >= 0 && prepared.face_origin[working] != f) {
      out.labels[f] = out.labels[prepared.face_origin[working]];
      out.transition[f] = out.transition[prepared.face_origin[working]];
    }
  }
}

// The summary of every patch: its kind, histogram range, mean H and K (area-weighted over the
// working mesh's faces, `area`) and its input triangles and area.
void summarize_patches(const TriangleMesh& input, const Eigen::VectorXd& area, const std::vector<int>& face_class,
                       int num_patches, Segmentation& out) {
  const TriangleMesh& mesh = out.working.mesh;
  const Eigen::VectorXd& H = out.mean_curvature;
  const int nf_input = input.num_faces();
  out.patches.resize(num_patches);
  std::vector<double> curvature_area(num_patches, 0.0);
  for (int p = 0; p < num_patches; ++p) {
    out.patches[p].id = p;
    out.patches[p].range_low = out.patches[p].range_high = std::numeric_limits<double>::quiet_NaN();
  }
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const int p = out.working_labels[f];
    if (p == kTransition) continue;
    PatchSummary& s = out.patches[p];
    const int cls = face_class[f];
    if (cls == kSharpConcave) s.kind = PatchKind::SharpConcave;
    else if (cls == kSharpConvex) s.kind = PatchKind::SharpConvex;
    else if (cls >= kSmoothBase) {
      s.range_low = out.histogram.range_lower(cls - kSmoothBase);
      s.range_high = out.histogram.range_upper(cls - kSmoothBase);
    }
    const double face_h = (H[mesh.F(f, 0)] + H[mesh.F(f, 1)] + H[mesh.F(f, 2)]) / 3.0;
    const Eigen::VectorXd& K = out.gaussian_curvature;
    const double face_k = (K[mesh.F(f, 0)] + K[mesh.F(f, 1)] + K[mesh.F(f, 2)]) / 3.0;
    s.mean_curvature += area[f] * face_h;
    s.mean_gaussian += area[f] * face_k;
    curvature_area[p] += area[f];
  }
  const Eigen::VectorXd input_area = face_areas(input);
  for (int f = 0; f < nf_input; ++f)
    if (out.labels[f] != kTransition) {
      ++out.patches[out.labels[f]].input_triangles;
      out.patches[out.labels[f]].area += input_area[f];
    }
  for (int p = 0; p < num_patches; ++p)
    if (curvature_area[p] > 0.0) {
      out.patches[p].mean_curvature /= curvature_area[p];
      out.patches[p].mean_gaussian /= curvature_area[p];
    }
}

}  // namespace

Segmentation segment_mesh(const TriangleMesh& input, const SegmentationOptions& options) {
  Segmentation out;
  StageTimer timer(out.timings);
  // Shares of the whole run, as measured on a scan of a million triangles: denoising dominates.
  const ProgressSpan progress(options.progress, "prepare");
  progress.step(0.0);  // a cancelled Progress stops here, before any work

  PreparedMesh prepared = prepare_mesh(input, progress.sub(0.0, 0.04));
  out.removed_degenerate = prepared.removed_degenerate;
  out.removed_duplicate = prepared.removed_duplicate;
  {
    std::optional<MeshTopology> topology(std::in_place, prepared.mesh);
    progress.step(0.055);
    timer.stage("prepare");
    // Checks; the orientation repair turns faces of the working copy over (the corners of a turned
    // face change places, so its adjacency is rebuilt).
    out.mesh_check = check_mesh(prepared.mesh, *topology, options.check, progress.sub("check", 0.055, 0.07));
    out.mesh_check.degenerate_removed = prepared.removed_degenerate;
    out.mesh_check.duplicate_removed = prepared.removed_duplicate;
    out.mesh_check.unused_vertices_removed = prepared.removed_unused_vertices;
    if (!out.mesh_check.flipped.empty()) {
      apply_orientation(prepared.mesh, out.mesh_check);
      out.input_flipped = flipped_in_input(input, prepared, out.mesh_check.flipped);
      out.mesh_check.flipped = {};
      topology.emplace(prepared.mesh);
    }
    timer.stage("check");
    out.working = refine_long_triangles(prepared.mesh, *topology, options.refinement, progress.sub("refine", 0.07, 0.16));
    for (int& origin : out.working.face_origin) origin = prepared.face_origin[origin];
  }
  const TriangleMesh& mesh = out.working.mesh;
  const MeshTopology topology(mesh);
  const int nv = mesh.num_vertices();
  timer.stage("refine");
  progress.sub("refine", 0.16, 0.18).step(1.0);

  {
    TriangleMesh denoised;
    // A vertex whose curvature radius is below k edge lengths lies on a fold of more than about 1/k
    // radians: pass 1 calls it sharp, and denoising must not take it for noise.
    DenoisingOptions denoising = options.denoising;
    if (denoising.edge_fold <= 0.0) denoising.edge_fold = 1.0 / options.sharp_radius_in_edges;
    denoised.V = denoised_positions(mesh, topology, denoising, progress.sub("denoise", 0.18, 0.88));
    denoised.F = mesh.F;
    VertexCurvature curvature = vertex_curvature(denoised, topology, progress.sub("curvature", 0.88, 0.93));
    out.mean_curvature = std::move(curvature.mean);
    out.gaussian_curvature = std::move(curvature.gaussian);
    out.vertex_area = std::move(curvature.area);
  }
  const Eigen::VectorXd& H = out.mean_curvature;
  timer.stage("curvature");

  // Pass 1 cuts out the sharpest features. The thesis takes the extremity peaks of the histogram;
  // after chamfering by the sampling, sharp edges spread into a low plateau whose inner valley the
  // histogram does not show reliably, so the cut is made where the sampling itself stops resolving
  // a surface: a curvature radius below `sharp_radius_in_edges` local edge lengths.
  const Eigen::VectorXd edge_length = local_edge_length(mesh, topology);
  std::vector<int> vertex_class(nv, kSmoothBase);
  std::vector<char> non_sharp(nv, 0);
  for (int v = 0; v < nv; ++v) {
    const double limit = 1.0 / (2.0 * options.sharp_radius_in_edges * edge_length[v]);
    if (H[v] < -limit) vertex_class[v] = kSharpConcave;
    else if (H[v] > limit) vertex_class[v] = kSharpConvex;
    else non_sharp[v] = 1;
  }
  timer.stage("pass1");
  const ProgressSpan histograms = progress.sub("histograms", 0.93, 0.965);
  histograms.step(0.0);

  // Pass 2: the curvature values inside the non-sharp patches (their rims excluded, which carry
  // the flanks of chamfered edges) are smoothed, the histogram is rebuilt, and every remaining
  // valley splits it.
  const std::vector<char> smooth_region = region_interior(mesh.F, non_sharp);
  out.smoothed_mean = smooth_values(H, out.vertex_area, smooth_region, topology,
                                    options.curvature_smoothing_iterations, histograms.sub(0.0, 0.8));
  std::vector<double> hs(out.smoothed_mean.data(), out.smoothed_mean.data() + nv);
  out.histogram = histogram_ranges(hs, smooth_region, options.histogram);
  for (int v = 0; v < nv; ++v)
    if (non_sharp[v]) vertex_class[v] = kSmoothBase + out.histogram.range_of(hs[v]);
  {
    // Where the histogram has no valley on one side of zero, the range is mirrored; with none on
    // either side, one bin is the finest zero the histogram resolves.
    const int zero = out.histogram.range_of(0.0);
    double low = out.histogram.range_lower(zero), high = out.histogram.range_upper(zero);
    const double bin = out.histogram.histogram.bin_width();
    if (!std::isfinite(low) && !std::isfinite(high)) low = -bin, high = bin;
    else if (!std::isfinite(low)) low = -high;
    else if (!std::isfinite(high)) high = -low;
    out.zero_low = std::min(low, 0.0);
    out.zero_high = std::max(high, 0.0);
  }
  const std::vector<int> face_class = face_classes(mesh.F, vertex_class);
  const int num_classified = face_components(topology, face_class, out.working_labels);
  timer.stage("pass2");

  const ProgressSpan thinning = progress.sub("thinning", 0.965, 0.985);
  thinning.step(0.0);
  dissolve_slivers(mesh, topology, out.working_labels, num_classified);
  grow_patches(mesh, topology, out.smoothed_mean, num_classified, false, out.working_labels, thinning.sub(0.0, 0.5));
  std::vector<char> working_transition(mesh.num_faces());
  for (int f = 0; f < mesh.num_faces(); ++f) working_transition[f] = out.working_labels[f] == kTransition;
  thinning.step(0.5);
  grow_patches(mesh, topology, out.smoothed_mean, num_classified, true, out.working_labels, thinning.sub(0.5, 1.0));
  timer.stage("thinning");
  const ProgressSpan map_back = progress.sub("map_back", 0.985, 1.0);
  map_back.step(0.0);

  const Eigen::VectorXd area = face_areas(mesh);
  map_back_labels(input, prepared, area, working_transition, out);
  const int num_patches = compact_patches(out.labels, out.working_labels, num_classified);

  summarize_patches(input, area, face_class, num_patches, out);
  timer.stage("map_back");
  map_back.step(1.0);
  return out;
}

}  // namespace idealize
