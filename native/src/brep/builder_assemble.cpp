// Healing, sewing and the facets joined into shells and solids (builder.h).
#include "brep/builder.h"

#include <TopExp.hxx>
#include <TopTools_IndexedMapOfShape.hxx>

#include <functional>

namespace idealize {

namespace {

// Raises an edge's tolerance to cover a gap between its curves larger than it (by 1 %), and its
// vertices' to at least as much.
void cover_gap(const TopoDS_Edge& edge, double gap) {
  if (!(gap > BRep_Tool::Tolerance(edge))) return;
  BRep_Builder builder;
  const double tolerance = 1.01 * gap;
  builder.UpdateEdge(edge, tolerance);
  for (TopExp_Explorer v(edge, TopAbs_VERTEX); v.More(); v.Next())
    builder.UpdateVertex(TopoDS::Vertex(v.Current()), std::max(tolerance, BRep_Tool::Tolerance(TopoDS::Vertex(v.Current()))));
}

}  // namespace

// The sewn analytic faces and the facets, whose edges and vertices are replaced by those that
// healing (`healed`) and then sewing made of them, grouped into connected shells.
TopoDS_Shape BrepBuilder::with_facets(const TopoDS_Shape& sewn, const BRepBuilderAPI_Sewing& sewing,
                                      ShapeBuild_ReShape& healed) const {
  BRepTools_ReShape replace;
  TopTools_IndexedMapOfShape parts;
  for (size_t i = 0; i < faces_.size(); ++i)
    if (face_facet_[i]) {
      TopExp::MapShapes(faces_[i], TopAbs_EDGE, parts);
      TopExp::MapShapes(faces_[i], TopAbs_VERTEX, parts);
    }
  bool any = false;
  for (int k = 1; k <= parts.Extent(); ++k) {
    const TopoDS_Shape& part = parts(k);
    TopoDS_Shape now = healed.Value(part);
    if (sewing.IsModifiedSubShape(now)) now = sewing.ModifiedSubShape(now);
    if (now.IsSame(part) && now.Orientation() == part.Orientation()) continue;
    replace.Replace(part, now);
    any = true;
  }
  // All facets at once: an edge they share is rebuilt once, with its new vertices.
  BRep_Builder builder;
  TopoDS_Compound facets;
  builder.MakeCompound(facets);
  for (size_t i = 0; i < faces_.size(); ++i)
    if (face_facet_[i]) builder.Add(facets, faces_[i]);
  std::vector<TopoDS_Face> faces;
  for (TopExp_Explorer e(sewn, TopAbs_FACE); e.More(); e.Next()) faces.push_back(TopoDS::Face(e.Current()));
  for (TopExp_Explorer e(any ? replace.Apply(facets) : TopoDS_Shape(facets), TopAbs_FACE); e.More(); e.Next())
    faces.push_back(TopoDS::Face(e.Current()));
  TopoDS_Compound shells;
  builder.MakeCompound(shells);
  for (const TopoDS_Shell& shell : connected_shells(faces)) builder.Add(shells, shell);
  return shells;
}

bool BrepBuilder::valid(const TopoDS_Shape& shape, const ProgressSpan& progress) const {
  if (facet_region_.empty()) return is_valid(shape, true);
  return !has_vanishing_edge(shape) &&
         is_valid_with_facets(shape, [&](const TopoDS_Face& face) { return is_facet(face); }, progress);
}

TopoDS_Shape BrepBuilder::assemble(BrepResult& result, const BrepOptions& options,
                                   std::vector<std::string>& closed_faults) {
  // Each face that needs it is healed on its own (pcurves shifted into one period, seams of
  // closed faces, degenerate edges at poles), then the faces are sewn: healing may replace an
  // edge in one face and not in its neighbour, and healing the whole shell at once
  // (ShapeFix_Shell) crashes on such shells in OCCT 7.6.
  if (faces_.empty()) {  // nothing to sew: an empty compound, no solid
    TopoDS_Compound nothing;
    BRep_Builder().MakeCompound(nothing);
    result.valid = true;
    result.closed = false;
    return nothing;
  }
  const std::vector<char> stray = fit_edge_tolerances(result);
  const std::vector<char> sound = sound_faces();
  const ProgressSpan progress = progress_.sub("sewing", 0.83, 0.9);
  if (std::all_of(face_facet_.begin(), face_facet_.end(), [](char facet) { return facet != 0; }))
    return facets_only(result, progress);
  const bool with_facet = std::any_of(face_facet_.begin(), face_facet_.end(), [](char facet) { return facet != 0; });
  TopoDS_Shape shape = sew(result, stray, sound, progress);
  cover_sewn_pcurve_gaps(shape);
  // Closed shells become solids (one per body).
  std::vector<TopoDS_Shell> shells;
  int shell_faces = 0, faces = 0;
  for (TopExp_Explorer e(shape, TopAbs_SHELL); e.More(); e.Next()) {
    shells.push_back(TopoDS::Shell(e.Current()));
    for (TopExp_Explorer f(e.Current(), TopAbs_FACE); f.More(); f.Next()) ++shell_faces;
  }
  for (TopExp_Explorer f(shape, TopAbs_FACE); f.More(); f.Next()) ++faces;
  const bool closed = !shells.empty() && shell_faces == faces && !has_free_edges(shape);
  result.closed = closed;
  if (closed) shape = solids_from_shells(shells);
  // (Not with facets: merging thousands of them takes minutes.)
  if (options.unify && closed && !with_facet) {
    // Merging is a refinement: where OCCT's merging fails (it faults on some edges) or leaves an
    // invalid face (a circle cut where a sphere cap's seam met it, whose pcurve then wraps the
    // wrong way) of a valid solid, the faces stay as they are. Only on a closed solid: on an open
    // shell of many faces OCCT 7.6's merging ran for minutes (a fragmented CAD torus blend). The
    // merged shape is checked first: it is usually valid, and then the one check is all.
    try {
      OCC_CATCH_SIGNALS
      ShapeUpgrade_UnifySameDomain unify(shape, Standard_True, Standard_True, Standard_False);
      unify.SetLinearTolerance(tol_ * 1e-3);
      unify.Build();
      // (Merging may also leave faces that BRepCheck passes and no mesh covers: the sides of a
      // noisy rounded plate, merged with its corner cylinders, came out as planes bounded by their
      // whole outline.)
      std::vector<std::string> faults = closed_shell_faults(unify.Shape(), 0.01 * diagonal_, tol_);
      result.valid = is_valid(unify.Shape(), true) && no_faults(faults);
      if (result.valid) closed_faults = std::move(faults);
      if (result.valid || !is_valid(shape, true)) return unify.Shape();
    } catch (const Standard_Failure&) {
    }
  }
  result.valid = with_facet ? valid(shape, progress.sub(0.8, 1.0)) : is_valid(shape, true);
  return shape;
}

// An edge's tolerance raised to cover its pcurves, and tangent crossings beside vertices covered;
// returns the faces whose boundary strays from their surface (failed, left out).
std::vector<char> BrepBuilder::fit_edge_tolerances(BrepResult& result) {
  // A circle on a sphere that is no parallel (a ball corner's rim) gets an approximated pcurve that
  // strays from the circle by more than the exact circle's tolerance, which BRepCheck accepts and
  // the boolean operations' check does not. The checks only read the faces (on two threads, edge by edge: a few B-spline edges of a scan
  // that does not close take most of the time); the tolerances are raised in face order.
  const int face_count = static_cast<int>(faces_.size());
  struct PcurveGap {
    int face;
    TopoDS_Edge edge;
    double gap = -1.0;   // none measured
    bool stray = false;  // its curves lie kStrayEdge tolerances apart or more
  };
  std::vector<PcurveGap> pcurve_gaps;
  for (int i = 0; i < face_count; ++i)  // (a facet's edges lie in its plane: their pcurves are exact)
    if (!face_facet_[i])
      for (TopExp_Explorer e(faces_[i], TopAbs_EDGE); e.More(); e.Next()) pcurve_gaps.push_back({i, TopoDS::Edge(e.Current())});
  on_two_threads_as_free(static_cast<int>(pcurve_gaps.size()), [&](int k) {
    PcurveGap& g = pcurve_gaps[k];
    try {
      OCC_CATCH_SIGNALS
      g.stray = sampled_pcurve_gap(g.edge, faces_[g.face]) >= kStrayEdge * tol_;
      if (g.stray) return;
      BRepLib_CheckCurveOnSurface check(g.edge, faces_[g.face]);
      check.Perform();
      // (A distance beyond the part's size is the check failing: no tolerance to take from it.)
      if (check.IsDone() && check.MaxDistance() <= diagonal_) g.gap = check.MaxDistance();
    } catch (const Standard_Failure&) {
    }
  }, progress_);
  // A face whose boundary strays that far from its surface does not follow it: where the surfaces on
  // either side of an edge do not meet near the mesh's border between them (a scan that does not
  // close), the edge fitted to that border lies off them. It is left out, and said so.
  std::vector<char> stray(face_count, 0);
  for (const PcurveGap& g : pcurve_gaps) stray[g.face] |= g.stray;
  for (int i = 0; i < face_count; ++i)
    if (stray[i]) {
      const std::string why = "its face does not follow its boundary (an edge lies more than " +
                              std::to_string(static_cast<int>(kStrayEdge)) + " tolerances off its surface)";
      result.problems.push_back({topo_.region_feature[face_region_[i]], why + ": left out"});
      fail(face_region_[i], why);
    }
  for (const PcurveGap& g : pcurve_gaps) cover_gap(g.edge, g.gap);
  for (int i = 0; i < face_count; ++i) {
    if (face_facet_[i]) continue;
    try {
      OCC_CATCH_SIGNALS
      cover_tangent_crossings(faces_[i], tol_);
    } catch (const Standard_Failure&) {
    }
  }
  return stray;
}

// Sewing makes the edges that two faces share anew, with pcurves of its own and the tolerance it
// measures by sampling them; between samples a fitted edge's curves may part by a little more,
// which the boolean operations' check (which searches for the largest gap) rejects. Each edge of
// an analytic face gets the tolerance that covers the largest gap found, up to the stray-edge
// bound (beyond it, the edge does not follow the face, and the face is to fail).
void BrepBuilder::cover_sewn_pcurve_gaps(const TopoDS_Shape& shape) const {
  struct Use {
    TopoDS_Edge edge;
    TopoDS_Face face;
    double gap = 0.0;
  };
  std::vector<Use> uses;
  for (TopExp_Explorer f(shape, TopAbs_FACE); f.More(); f.Next()) {
    const TopoDS_Face& face = TopoDS::Face(f.Current());
    if (is_facet(face)) continue;  // (a facet's edges lie in its plane: their pcurves are exact)
    for (TopExp_Explorer e(face, TopAbs_EDGE); e.More(); e.Next()) uses.push_back({TopoDS::Edge(e.Current()), face});
  }
  on_two_threads_as_free(static_cast<int>(uses.size()), [&](int k) {
    Use& use = uses[k];
    if (BRep_Tool::Degenerated(use.edge)) return;
    try {
      OCC_CATCH_SIGNALS
      BRepLib_CheckCurveOnSurface check(use.edge, use.face);
      check.Perform();
      if (check.IsDone()) use.gap = check.MaxDistance();
    } catch (const Standard_Failure&) {
    }
  }, progress_);
  for (const Use& use : uses)
    if (use.gap < kStrayEdge * tol_) cover_gap(use.edge, use.gap);
}

namespace {

// Whether `healed` (ShapeFix_Face's result for `face`, its replacements in `context`) still holds
// every edge of `face`, or what healing replaced it by: healing may add a seam, split or rebuild
// an edge, but a face that lost an edge no longer closes against the neighbour across it. (An edge
// healing replaced may be replaced again, by pieces where the seam crosses it: followed to the
// end.)
bool keeps_boundary(const TopoDS_Face& face, const TopoDS_Face& healed, const Handle(ShapeBuild_ReShape)& context) {
  TopTools_IndexedMapOfShape kept;
  TopExp::MapShapes(healed, TopAbs_EDGE, kept);
  const std::function<bool(const TopoDS_Shape&, int)> held = [&](const TopoDS_Shape& edge, int depth) {
    if (kept.Contains(edge)) return true;
    if (context.IsNull() || !context->IsRecorded(edge) || depth > kept.Extent()) return false;
    const TopoDS_Shape now = context->Value(edge);
    if (now.IsNull() || now.IsSame(edge)) return false;
    bool all = true;
    for (TopExp_Explorer piece(now, TopAbs_EDGE); piece.More() && all; piece.Next())
      all = held(piece.Current(), depth + 1);
    return all;
  };
  for (TopExp_Explorer e(face, TopAbs_EDGE); e.More(); e.Next())
    if (!BRep_Tool::Degenerated(TopoDS::Edge(e.Current())) && !held(e.Current(), 0)) return false;
  return true;
}

}  // namespace

// The faces that need no healing: valid as built (planar facets by construction), and bounded.
std::vector<char> BrepBuilder::sound_faces() const {
  const int face_count = static_cast<int>(faces_.size());
  // Healing only where needed: invalid faces, and faces bounded by nothing (a whole sphere or torus
  // gets its natural bounds). Each face is judged as built (on two threads: a few faces of a scan
  // that does not close take most of the time), before healing touches its neighbours' edges.
  std::vector<char> sound(face_count, 0);
  on_two_threads_as_free(face_count, [&](int i) {
    if (face_facet_[i]) {  // valid by construction
      sound[i] = 1;
      return;
    }
    try {
      OCC_CATCH_SIGNALS
      sound[i] = TopExp_Explorer(faces_[i], TopAbs_WIRE).More() && is_valid(faces_[i]);
    } catch (const Standard_Failure&) {
    }
  }, progress_);
  return sound;
}

// Facets only: they share their edges already, and sewing thousands of them is slow.
TopoDS_Shape BrepBuilder::facets_only(BrepResult& result, const ProgressSpan& progress) {
  const std::vector<TopoDS_Shell> shells = connected_shells(faces_);
  result.closed = std::none_of(shells.begin(), shells.end(), [](const TopoDS_Shell& shell) { return has_free_edges(shell); });
  TopoDS_Shape shape;
  if (result.closed) {
    shape = solids_from_shells(shells);
  } else {
    BRep_Builder builder;
    TopoDS_Compound open;
    builder.MakeCompound(open);
    for (const TopoDS_Shell& shell : shells) builder.Add(open, shell);
    shape = open;
  }
  result.valid = valid(shape, progress.sub(0.5, 1.0));
  return shape;
}

// The analytic faces healed where needed and sewn, the facets joined (with_facets); one face sewn
// to itself (a whole sphere) as a shell.
TopoDS_Shape BrepBuilder::sew(BrepResult& result, const std::vector<char>& stray, const std::vector<char>& sound,
                              const ProgressSpan& progress) {
  const int face_count = static_cast<int>(faces_.size());
  // The analytic faces are sewn; the facets, which share their edges and vertices exactly, are not
  // (sewing thousands of them takes minutes): they take the edges and vertices that healing and
  // sewing put in place of theirs.
  // (Its analysis drops edges shorter than the tolerance, which a polyline along the mesh has
  // many of, and which the facets keep.)
  const bool with_facet = std::any_of(face_facet_.begin(), face_facet_.end(), [](char facet) { return facet != 0; });
  BRepBuilderAPI_Sewing sewing(tol_, Standard_True, !with_facet);
  const Handle(ShapeBuild_ReShape) healed = new ShapeBuild_ReShape;
  for (int i = 0; i < face_count; ++i) {
    progress.sub(0.0, 0.5).step(static_cast<double>(i) / face_count);
    if (stray[i] || face_facet_[i]) continue;
    if (sound[i]) {
      sewing.Add(faces_[i]);
      continue;
    }
    try {
      OCC_CATCH_SIGNALS
      ShapeFix_Face fix(faces_[i]);
      // Its periodic-degenerate check dereferences a null curve on some faces (OCCT 7.6); our
      // spheres and cones have their poles and apices away from the faces anyway.
      fix.FixPeriodicDegeneratedMode() = 0;
      fix.SetPrecision(Precision::Confusion());
      fix.SetMaxTolerance(tol_);
      fix.Perform();
      // The seam that healing adds to a band on a torus comes out flagged same-parameter when
      // its curves are not (BRepCheck_InvalidSameParameterFlag): set them so.
      ShapeFix_Edge same_parameter;
      for (TopExp_Explorer e(fix.Face(), TopAbs_EDGE); e.More(); e.Next())
        same_parameter.FixSameParameter(TopoDS::Edge(e.Current()));
      // What it replaced, for the facets that share those edges and vertices (its own record:
      // given one, it copies the edges it changes instead of changing them for both faces).
      const Handle(ShapeBuild_ReShape) context = fix.Context();
      if (!keeps_boundary(faces_[i], fix.Face(), context)) {
        // (Healing a band on a torus whose loops it could not join kept a corner of it.)
        const std::string why = "healing its face lost part of its boundary";
        result.problems.push_back({topo_.region_feature[face_region_[i]], why});
        fail(face_region_[i], why);
        continue;
      }
      for (const TopAbs_ShapeEnum type : {TopAbs_EDGE, TopAbs_VERTEX})
        if (!context.IsNull())
          for (TopExp_Explorer e(faces_[i], type); e.More(); e.Next())
            if (const TopoDS_Shape now = context->Value(e.Current()); !now.IsSame(e.Current())) healed->Replace(e.Current(), now);
      sewing.Add(fix.Face());
    } catch (const Standard_Failure& failure) {
      result.problems.push_back({topo_.region_feature[face_region_[i]], occt_message(failure, "its face could not be healed")});
      fail(face_region_[i], occt_message(failure, "its face could not be healed"));
    }
  }
  progress.step(0.5);
  Handle(OcctProgress) indicator = new OcctProgress(progress.sub(0.5, 0.8));
  sewing.Perform(indicator->Start());
  progress.step(0.8);  // throws Cancelled when sewing stopped early
  TopoDS_Shape shape = sewing.SewedShape();
  if (with_facet) shape = with_facets(shape, sewing, *healed);
  if (shape.ShapeType() == TopAbs_FACE) {  // a single face (a whole sphere) is sewn to itself
    BRep_Builder builder;
    TopoDS_Shell shell;
    builder.MakeShell(shell);
    builder.Add(shell, shape);
    shape = shell;
  }

  return shape;
}

}  // namespace idealize
