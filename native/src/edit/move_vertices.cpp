#include "edit/move_vertices.h"

#include "core/parallel.h"
#include "edit/contacts.h"

#include <Eigen/Cholesky>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseLU>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <string>

namespace idealize {
namespace {

// Gauss-Newton steps of least norm onto the zero sets of `surfaces` (a point on all of them).
Eigen::Vector3d least_norm_steps(const std::vector<const Surface*>& surfaces, Eigen::Vector3d p, double length) {
  const int k = static_cast<int>(surfaces.size());
  if (k == 0) return p;
  for (int iteration = 0; iteration < 8; ++iteration) {
    Eigen::MatrixXd J(k, 3);
    Eigen::VectorXd r(k);
    for (int i = 0; i < k; ++i) {
      r(i) = signed_distance(*surfaces[i], p);
      J.row(i) = surface_normal(*surfaces[i], p).transpose();
    }
    // Converged to the rounding of the distances (about 1e-16 of the part).
    if (r.cwiseAbs().maxCoeff() <= 1e-14 * length) break;
    // Damped: two surfaces nearly tangent give nearly equal rows; 1e-12 keeps the step finite
    // and changes a transversal step by 1e-12 of itself.
    Eigen::MatrixXd A = J * J.transpose();
    A.diagonal().array() += 1e-12;
    p -= J.transpose() * A.ldlt().solve(r);
  }
  return p;
}

bool same_shape(const Surface& a, const Surface& b) {
  return a.radius == b.radius && a.minor == b.minor && a.half_angle == b.half_angle;
}

// The correction of the free vertices (index >= 0, n_free of them), carried by `carried`, that
// makes them the harmonic interpolation of their borders' misfit: a placed vertex w (in `V`
// already) pulls a free neighbour v by V(w) - carried(v) * w, and a free neighbour carried
// otherwise by the difference of the carries. A stretched wall's vertices (carried
// nowhere) spread its moved border over it; a moved feature's vertices follow where its border
// lands (a fillet moved against a mitre with another). Mean value weights (Floater, "Mean value
// coordinates", CAGD 2003): positive, and exact for a misfit that varies linearly over a flat
// region, so that rows of vertices stay in order (uniform weights, blind to spacing, pushed a
// wall's thin top row past its edge). A free vertex on the border of two features (`around` holds
// two) interpolates along that border only, by arc length (weights 1 / length towards the
// neighbours on the same border or at its ends): a border that shortens between its corners
// spreads its vertices evenly instead of piling them at a corner.
Eigen::MatrixXd harmonic_correction(const TriangleMesh& mesh, const std::vector<int>& index, int n_free,
                                    const std::vector<Eigen::Isometry3d>& carried, const MatrixX3d& V,
                                    const std::vector<std::vector<int>>& around) {
  std::vector<std::map<int, double>> weights(n_free);
  const MeshTopology topology(mesh);
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (index[v] < 0 || around[v].size() != 2) continue;
    for (const int* w = topology.vertex_neighbors_begin(v); w != topology.vertex_neighbors_end(v); ++w) {
      const auto& b = around[*w];
      const bool along = std::includes(b.begin(), b.end(), around[v].begin(), around[v].end());
      const double length = (mesh.V.row(*w) - mesh.V.row(v)).norm();
      if (along && length > 0.0) weights[index[v]][*w] += 1.0 / length;
    }
  }
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int i = mesh.F(f, c), j = mesh.F(f, (c + 1) % 3), k = mesh.F(f, (c + 2) % 3);
      if (index[i] < 0 || around[i].size() == 2) continue;
      const Eigen::Vector3d x = mesh.V.row(i), a = mesh.V.row(j).transpose() - x, b = mesh.V.row(k).transpose() - x;
      const double la = a.norm(), lb = b.norm();
      if (!(la > 0.0 && lb > 0.0)) continue;
      const double half = std::tan(0.5 * std::acos(std::clamp(a.dot(b) / (la * lb), -1.0, 1.0)));
      weights[index[i]][j] += half / la;
      weights[index[i]][k] += half / lb;
    }
  // The free vertices of each feature's inside (or each border) make a system of their own,
  // between placed vertices: solved apart, on both cores, largest first.
  std::vector<int> vertex_of(n_free);
  for (int v = 0; v < static_cast<int>(index.size()); ++v)
    if (index[v] >= 0) vertex_of[index[v]] = v;
  std::vector<int> component(n_free, -1);
  std::vector<std::vector<int>> members;
  for (int start = 0; start < n_free; ++start) {
    if (component[start] >= 0) continue;
    members.emplace_back();
    std::vector<int> stack{start};
    component[start] = static_cast<int>(members.size()) - 1;
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      members.back().push_back(i);
      for (const auto& [w, weight] : weights[i])
        if (index[w] >= 0 && component[index[w]] < 0) {
          component[index[w]] = component[start];
          stack.push_back(index[w]);
        }
    }
  }
  std::vector<int> order(members.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return members[a].size() > members[b].size(); });
  Eigen::MatrixXd correction = Eigen::MatrixXd::Zero(n_free, 3);
  std::vector<char> failed(members.size(), 0);
  on_two_threads(order, [&](int c) {
    const std::vector<int>& rows = members[c];
    std::map<int, int> position;
    for (size_t r = 0; r < rows.size(); ++r) position[rows[r]] = static_cast<int>(r);
    std::vector<Eigen::Triplet<double>> entries;
    Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(rows.size()), 3);
    for (size_t r = 0; r < rows.size(); ++r) {
      const int v = vertex_of[rows[r]];
      double total = 0.0;
      for (const auto& [w, weight] : weights[rows[r]]) {
        total += weight;
        const Eigen::Vector3d x = mesh.V.row(w).transpose();
        if (index[w] >= 0) {
          // A free neighbour carried otherwise (a wall's vertex beside the border a pushed face
          // carries): its correction counts in v's frame, the difference of the carries known.
          entries.emplace_back(static_cast<int>(r), position.at(index[w]), -weight);
          rhs.row(static_cast<Eigen::Index>(r)) += weight * (carried[w] * x - carried[v] * x).transpose();
        } else {
          rhs.row(static_cast<Eigen::Index>(r)) += weight * (V.row(w).transpose() - carried[v] * x).transpose();
        }
      }
      // A tiny pull to zero keeps a free region without any placed neighbour (a border loop with
      // no corner, an open mesh's patch) determined: 1e-12 of its weights.
      entries.emplace_back(static_cast<int>(r), static_cast<int>(r), total * (1.0 + 1e-12));
    }
    Eigen::SparseMatrix<double> L(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(rows.size()));
    L.setFromTriplets(entries.begin(), entries.end());
    Eigen::SparseLU<Eigen::SparseMatrix<double>> solver;
    solver.compute(L);
    if (solver.info() != Eigen::Success) {
      failed[c] = 1;
      return;
    }
    const Eigen::MatrixXd solved = solver.solve(rhs);
    for (size_t r = 0; r < rows.size(); ++r) correction.row(rows[r]) = solved.row(static_cast<Eigen::Index>(r));
  }, ProgressSpan());
  if (std::any_of(failed.begin(), failed.end(), [](char f) { return f; }))
    throw EditConflict("the edited features' vertices could not be placed");
  return correction;
}

// Throws EditConflict when a vertex would leave the part: moved further than the edit moves any
// point of its changed features plus the part's bounding-box diagonal `length`. Harmonic
// interpolation moves no vertex further than its borders, and a border vertex follows its
// surfaces' intersection; such a vertex went to where two nearly tangent surfaces (no tangent pair
// of the layer) cross far from the mesh's border between them. Remeshing it would build a
// surface the size of that distance at the feature's edge length (billions of triangles).
void refuse_runaway(const TriangleMesh& mesh, const MatrixX3d& V, const std::vector<std::vector<int>>& around,
                    const std::vector<Surface>& after, const std::vector<char>& changed,
                    const std::vector<Eigen::Isometry3d>& motions, double length) {
  double reach = 0.0;  // the farthest the edit itself carries a point of a changed feature
  for (int v = 0; v < mesh.num_vertices(); ++v)
    for (int f : around[v])
      if (changed[f]) {
        const Eigen::Vector3d x = mesh.V.row(v).transpose();
        reach = std::max(reach, (closest_point(after[f], motions[f] * x) - x).norm());
      }
  // The one to name: on the most features (the interior ones follow their borders), then the
  // farthest; a vertex sent to infinity counts as farthest.
  int worst = -1;
  auto distance = [&](int v) {
    const double moved = (V.row(v) - mesh.V.row(v)).norm();
    return std::isfinite(moved) ? moved : std::numeric_limits<double>::infinity();
  };
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (distance(v) <= reach + length) continue;
    if (worst < 0 ||
        std::make_pair(around[v].size(), distance(v)) > std::make_pair(around[worst].size(), distance(worst)))
      worst = v;
  }
  if (worst < 0) return;
  std::string names;
  for (int f : around[worst])
    names += std::string(names.empty() ? "" : " and ") + std::to_string(f) + " (" +
             surface_type_name(after[f].type) + ")";
  throw EditConflict("the edit would carry the border of features " + names +
                     " far outside the part: their surfaces no longer cross near that border (nearly "
                     "tangent); the layer is unchanged");
}

}  // namespace

Eigen::Vector3d onto_features(const std::vector<int>& features, const std::vector<Surface>& surfaces,
                              const std::set<std::pair<int, int>>& g1, Eigen::Vector3d p, double length) {
  std::vector<int> analytic;
  for (int f : features)
    if (f >= 0 && surfaces[f].type != SurfaceType::Freeform) analytic.push_back(f);
  if (analytic.empty()) return p;
  if (analytic.size() == 1) return closest_point(surfaces[analytic[0]], p);
  // Tangent pairs: their contact line replaces the two surfaces, whose normals agree along it.
  std::vector<std::pair<int, int>> contacts;  // roller, other
  std::vector<char> rolls(analytic.size(), 0);
  for (size_t i = 0; i < analytic.size(); ++i)
    for (size_t j = i + 1; j < analytic.size(); ++j) {
      const int a = analytic[i], b = analytic[j];
      if (!g1.count({std::min(a, b), std::max(a, b)})) continue;
      const int roller = roller_of(surfaces[a], a, surfaces[b], b);
      if (roller < 0) continue;
      contacts.emplace_back(roller, roller == a ? b : a);
      rolls[roller == a ? i : j] = 1;
    }
  std::vector<const Surface*> rest;
  for (size_t i = 0; i < analytic.size(); ++i)
    if (!rolls[i]) rest.push_back(&surfaces[analytic[i]]);
  if (contacts.empty()) return least_norm_steps(rest, p, length);
  // Alternating projections onto the contact lines and the other surfaces: they cross
  // transversally at a corner, where this converges linearly.
  for (int iteration = 0; iteration < 30; ++iteration) {
    const Eigen::Vector3d start = p;
    for (const auto& [roller, other] : contacts) p = contact_point(surfaces[roller], surfaces[other], p);
    if (rest.size() > 1 || contacts.size() > 1) p = least_norm_steps(rest, p, length);
    if ((p - start).norm() <= 1e-14 * length) break;
  }
  for (const auto& [roller, other] : contacts) p = contact_point(surfaces[roller], surfaces[other], p);
  return p;
}

MovedVertices move_vertices(const TriangleMesh& mesh, const std::vector<int>& labels,
                            const std::vector<FeatureAdjacency>& adjacency, const std::vector<Surface>& before,
                            const Propagation& propagation) {
  const std::vector<Surface>& after = propagation.surfaces;
  const std::vector<char>& changed = propagation.changed;
  const double length = bounding_box_diagonal(mesh);
  // Features that did not change but border one that did stretch with it.
  std::vector<char> stretch(before.size(), 0);
  std::set<std::pair<int, int>> g1;
  for (const FeatureAdjacency& a : adjacency) {
    if (changed[a.a] && !changed[a.b]) stretch[a.b] = 1;
    if (changed[a.b] && !changed[a.a]) stretch[a.a] = 1;
    if (a.continuity == Continuity::G1) g1.insert({std::min(a.a, a.b), std::max(a.a, a.b)});
  }
  const std::vector<std::vector<int>> around = features_around(mesh, labels);
  const int nv = mesh.num_vertices();
  MovedVertices out;
  out.V = mesh.V;
  // Where each vertex goes before the correction: with its feature's motion, or where it is.
  std::vector<Eigen::Isometry3d> carried(nv, Eigen::Isometry3d::Identity());
  std::vector<char> free(nv, 0);
  for (int v = 0; v < nv; ++v) {
    const auto& a = around[v];
    const Eigen::Vector3d x = mesh.V.row(v).transpose();
    const bool any_changed = std::any_of(a.begin(), a.end(), [&](int f) { return changed[f]; });
    const bool all_stretch = !a.empty() && std::all_of(a.begin(), a.end(), [&](int f) { return stretch[f]; });
    if (a.size() == 1 && (changed[a[0]] || stretch[a[0]])) {
      carried[v] = propagation.motions[a[0]];  // inside an edited feature: free, carried by it
      free[v] = 1;
    } else if (a.size() == 2 && (any_changed || all_stretch)) {
      // On the border of two edited features: free along it, carried by the changed one.
      for (int f : a)
        if (changed[f]) {
          carried[v] = propagation.motions[f];
          break;
        }
      free[v] = 1;
    } else if (any_changed) {
      // At a corner of a changed feature: each changed feature carries the vertex with its motion
      // onto its new surface, and the intersection of all its surfaces is searched from their mean.
      Eigen::Vector3d guess = Eigen::Vector3d::Zero();
      int count = 0;
      for (int f : a)
        if (changed[f]) {
          guess += closest_point(after[f], propagation.motions[f] * x);
          ++count;
        }
      out.V.row(v) = onto_features(a, after, g1, guess / count, length).transpose();
    } else if (all_stretch) {
      free[v] = 1;  // where stretched features meet: free, in place
    }
  }
  // The borders first, between their corners; then the features' insides between their borders.
  for (const bool border : {true, false}) {
    std::vector<int> index(nv, -1);
    int n_free = 0;
    for (int v = 0; v < nv; ++v)
      if (free[v] && (around[v].size() == 2) == border) index[v] = n_free++;
    if (n_free == 0) continue;
    const Eigen::MatrixXd correction = harmonic_correction(mesh, index, n_free, carried, out.V, around);
    for (int v = 0; v < nv; ++v)
      if (index[v] >= 0) {
        const Eigen::Vector3d x = carried[v] * Eigen::Vector3d(mesh.V.row(v).transpose()) +
                                  correction.row(index[v]).transpose();
        out.V.row(v) = onto_features(around[v], after, g1, x, length).transpose();
      }
  }
  refuse_runaway(mesh, out.V, around, after, changed, propagation.motions, length);
  // The region remeshing redoes.
  out.region.assign(mesh.num_faces(), 0);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const int l = labels[f];
    // A feature that only moved keeps its triangles (they moved rigidly with it).
    out.region[f] = l >= 0 && (stretch[l] || (changed[l] && !same_shape(before[l], after[l])));
  }
  return out;
}

std::vector<double> facing_sides(const TriangleMesh& mesh, const std::vector<int>& labels,
                                 const std::vector<Surface>& surfaces) {
  std::vector<double> facing(surfaces.size(), 0.0);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (labels[f] < 0 || surfaces[labels[f]].type == SurfaceType::Freeform) continue;
    const Surface& s = surfaces[labels[f]];
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    facing[labels[f]] += (b - a).cross(c - a).dot(surface_normal(s, (a + b + c) / 3.0));
  }
  for (double& side : facing) side = side < 0.0 ? -1.0 : 1.0;
  return facing;
}

double facing_cosine(const Surface& surface, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                     const Eigen::Vector3d& c) {
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double length = n.norm();
  return length > 0.0 ? n.dot(surface_normal(surface, (a + b + c) / 3.0)) / length : 0.0;
}

std::string inverted_triangles(const TriangleMesh& mesh, const std::vector<int>& labels,
                               const std::vector<Surface>& surfaces, const std::vector<double>& sides,
                               const std::vector<char>& edited) {
  std::map<int, int> inverted;  // feature -> triangles
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const int l = labels[f];
    if (l < 0 || !edited[l] || surfaces[l].type == SurfaceType::Freeform) continue;
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    // Turned over: facing against the feature's side. A triangle whose corners all lie on one border
    // curve of a round surface (CAD meshers put such triangles at fillets' ends) stands at right
    // angles to it: its facing is zero up to rounding, and its sign means nothing. A cosine below
    // -1e-6 (0.00006 degrees past the right angle, a thousand times the rounding's 1e-9) is a turn.
    if (sides[l] * facing_cosine(surfaces[l], a, b, c) < -1e-6) ++inverted[l];
  }
  if (inverted.empty()) return "";
  const auto worst = std::max_element(inverted.begin(), inverted.end(),
                                      [](const auto& x, const auto& y) { return x.second < y.second; });
  return std::to_string(worst->second) + " triangles of feature " + std::to_string(worst->first) + " (" +
         surface_type_name(surfaces[worst->first].type) + ")";
}

void refuse_inverted(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                     const std::vector<double>& sides, const std::vector<char>& edited,
                     const std::vector<int>& edit_of) {
  const std::string inverted = inverted_triangles(mesh, labels, surfaces, sides, edited);
  if (inverted.empty()) return;
  std::string what = "the edit of";
  for (size_t i = 0; i < edit_of.size(); ++i)
    what += (i ? ", feature " : " feature ") + std::to_string(edit_of[i]) + " (" +
            surface_type_name(surfaces[edit_of[i]].type) + ")";
  throw InvertedTriangles(what + " would turn over " + inverted +
                     ": the change is larger than that face allows; the layer is unchanged");
}

}  // namespace idealize
