// Faces on the fitted surfaces, bounded by their loops of edges (builder.h).
#include "brep/builder.h"

namespace idealize {
namespace {

// The pcurves of a wire that winds once round the axis of a u-periodic surface, made continuous in
// u from the vertex on the seam on (FixAddPCurve puts each in the period nearest the surface's):
// the loop then runs from the seam round to it, and healing closes the face along the seam. Were
// they left as they come, healing takes the stretch before the seam for a loop of its own.
void continue_pcurves(const TopoDS_Wire& wire, const TopoDS_Face& face) {
  if (has_vanishing_edge(face)) return;
  const double period = BRep_Tool::Surface(face)->UPeriod();
  struct Use {
    TopoDS_Edge edge;
    Handle(Geom2d_Curve) pcurve;
    gp_Pnt2d start, end;
  };
  std::vector<Use> uses;
  for (BRepTools_WireExplorer it(wire, face); it.More(); it.Next()) {
    double first, last;
    Use use{it.Current(), BRep_Tool::CurveOnSurface(it.Current(), face, first, last), {}, {}};
    if (use.pcurve.IsNull()) return;
    const bool reversed = use.edge.Orientation() == TopAbs_REVERSED;
    use.start = use.pcurve->Value(reversed ? last : first);
    use.end = use.pcurve->Value(reversed ? first : last);
    uses.push_back(use);
  }
  if (uses.empty()) return;
  auto off_seam = [&](double u) { return std::abs(std::remainder(u, period)); };
  const auto seam = std::min_element(uses.begin(), uses.end(),
                                     [&](const Use& x, const Use& y) { return off_seam(x.start.X()) < off_seam(y.start.X()); });
  std::rotate(uses.begin(), seam, uses.end());
  BRep_Builder builder;
  double u = uses.front().start.X() - std::remainder(uses.front().start.X(), period);  // the seam
  for (const Use& use : uses) {
    const double shift = period * std::round((u - use.start.X()) / period);
    if (shift != 0.0) {
      const Handle(Geom2d_Curve) moved = Handle(Geom2d_Curve)::DownCast(use.pcurve->Translated(gp_Vec2d(shift, 0.0)));
      builder.UpdateEdge(use.edge, moved, face, BRep_Tool::Tolerance(use.edge));
    }
    u = use.end.X() + shift;
  }
}

}  // namespace

// Whether a region goes all round the axis of its surface, and where its seam goes then. A loop of
// one closed chain goes round the axis of the surfaces on both sides (a sphere band takes the other
// side's as its polar axis); the seam goes along common_seam_direction. A loop of several chains
// that winds round the axis (a cone's rim cut by a slot) decides instead: its seam crosses the
// middle of the loop's longest chain, whose edge split_at_seam cuts there, so that healing joins
// the seam to vertices on both loops.
std::optional<RoundFace> BrepBuilder::round_face(int region) const {
  const Surface& s = surfaces_[topo_.region_feature[region]];
  if (s.type == SurfaceType::Freeform) return std::nullopt;
  std::optional<RoundFace> closed;  // from a closed chain; a winding loop beside it decides the seam
  for (const auto& loop : topo_.region_loops[region]) {
    const BoundaryChain& first = topo_.chains[loop.front().chain];
    if (loop.size() == 1 && first.closed) {
      const int across = first.left == region ? first.right : first.left;
      const Surface* other = across >= 0 ? &surfaces_[topo_.region_feature[across]] : nullptr;
      if (closed || (!s.has_direction() && !(other && other->has_direction()))) continue;
      const Vec3 axis = s.has_direction() ? s.axis : other->axis;
      closed = RoundFace{axis, common_seam_direction(axis)};
      continue;
    }
    // A band's loop (a single loop round the axis would bound a cap about a pole or apex).
    if (!s.has_direction() || s.type == SurfaceType::Plane || topo_.region_loops[region].size() < 2) continue;
    // The turn of the loop about the axis: ±2π when it winds round it.
    Vec3 e1, e2;
    orthonormal_frame(s.axis, e1, e2);
    double turn = 0.0, previous = 0.0;
    bool started = false;
    for (const ChainUse& use : loop) {
      const std::vector<int>& vertices = topo_.chains[use.chain].vertices;
      for (size_t i = 0; i < vertices.size(); ++i) {
        const Vec3 q = mesh_.V.row(vertices[use.forward ? i : vertices.size() - 1 - i]).transpose() - s.point;
        const double angle = std::atan2(q.dot(e2), q.dot(e1));
        if (started) turn += std::remainder(angle - previous, 2.0 * M_PI);
        previous = angle;
        started = true;
      }
    }
    if (std::abs(turn) < M_PI) continue;
    // The seam crosses the loop's longest chain at its middle: a seam through a corner would
    // run through the face above or below it wherever an edge there leans across (the walls of a
    // slot in a cone's rim narrow upwards).
    const auto longest = std::max_element(loop.begin(), loop.end(), [&](const ChainUse& x, const ChainUse& y) {
      return topo_.chains[x.chain].vertices.size() < topo_.chains[y.chain].vertices.size();
    });
    const std::vector<int>& vertices = topo_.chains[longest->chain].vertices;
    if (vertices.size() < 3) continue;
    const Vec3 q = mesh_.V.row(vertices[vertices.size() / 2]).transpose() - s.point;
    const Vec3 radial = q - q.dot(s.axis) * s.axis;
    if (radial.norm() > 1e-9 * diagonal_) return RoundFace{s.axis, radial.normalized(), true, longest->chain};
  }
  return closed;
}

// A cone or sphere bounded by one whole circle is a cap about its apex (a drill point) or pole (a
// ball end): its face is the surface between the circle and that point, with the seam and the
// degenerate edge there that a face built from the circle alone lacks. The sphere is placed with
// its pole inside the cap. Sewing joins the cap's circle to the neighbour's.
bool BrepBuilder::is_cap(size_t region) const {
  const auto& loops = topo_.region_loops[region];
  const Handle(Geom_Surface)& surface = region_surfaces_[region];
  return loops.size() == 1 && loops[0].size() == 1 && topo_.chains[loops[0][0].chain].closed &&
         (surface->IsKind(STANDARD_TYPE(Geom_ConicalSurface)) || surface->IsKind(STANDARD_TYPE(Geom_SphericalSurface)));
}

std::optional<TopoDS_Face> BrepBuilder::pole_cap(size_t region) {
  if (!is_cap(region)) return std::nullopt;
  const auto& loops = topo_.region_loops[region];
  const TopoDS_Edge& edge = edges_[loops[0][0].chain];
  if (edge.IsNull()) return std::nullopt;  // a polyline: the face is bounded by its pieces
  double first, last;
  const Handle(Geom_Circle) circle = Handle(Geom_Circle)::DownCast(BRep_Tool::Curve(edge, first, last));
  if (circle.IsNull()) return std::nullopt;
  // The surface's seam through the edge's vertex: the cap's circle then starts where the edge does,
  // and sewing joins the two whole (it would cut both at each other's vertices).
  const gp_Pnt start = BRep_Tool::Pnt(TopExp::FirstVertex(edge));
  const gp_Dir seam = gp_Vec(circle->Location(), start);
  Handle(Geom_Surface) placed;
  double low, high;
  if (const Handle(Geom_ConicalSurface) cone = Handle(Geom_ConicalSurface)::DownCast(region_surfaces_[region]);
      !cone.IsNull()) {
    const Handle(Geom_ConicalSurface) turned = new Geom_ConicalSurface(
        gp_Ax3(cone->Location(), cone->Axis().Direction(), seam), cone->SemiAngle(), cone->RefRadius());
    double u, v;
    ElSLib::Parameters(turned->Cone(), start, u, v);
    const double apex = -turned->RefRadius() / std::sin(turned->SemiAngle());
    placed = turned;
    low = std::min(apex, v);
    high = std::max(apex, v);
  } else if (const Handle(Geom_SphericalSurface) sphere = Handle(Geom_SphericalSurface)::DownCast(region_surfaces_[region]);
             !sphere.IsNull()) {
    gp_Dir pole = circle->Axis().Direction();
    if (gp_Vec(circle->Location(), to_pnt(region_centroid_[region])).Dot(gp_Vec(pole)) < 0.0) pole.Reverse();
    const Handle(Geom_SphericalSurface) turned = new Geom_SphericalSurface(gp_Ax3(sphere->Location(), pole, seam), sphere->Radius());
    double u, v;
    ElSLib::Parameters(turned->Sphere(), start, u, v);
    placed = turned;
    low = v;
    high = 0.5 * M_PI;
  } else {
    return std::nullopt;
  }
  BRepBuilderAPI_MakeFace cap(placed, 0.0, 2.0 * M_PI, low, high, Precision::Confusion());
  if (!cap.IsDone()) return std::nullopt;
  region_surfaces_[region] = placed;  // faces map back to features by their surface
  return cap.Face();
}

void BrepBuilder::make_faces(BrepResult& result) {
  BRep_Builder builder;
  faces_.clear();
  face_region_.clear();
  face_facet_.clear();
  const ProgressSpan progress = progress_.sub("faces", 0.8, 0.83);
  for (size_t r = 0; r < topo_.region_loops.size(); ++r) {
    progress.step(static_cast<double>(r) / topo_.region_loops.size());
    const int feature = topo_.region_feature[r];
    if (faceted_[r]) {
      for (int f : region_faces_[r]) {
        progress.poll(faces_.size(), 1 << 10);
        const std::optional<TopoDS_Face> facet = facets_->facet(f);
        if (!facet) continue;  // no area: its neighbours' edges meet across it
        const Handle(Geom_Surface) plane = BRep_Tool::Surface(*facet);
        facet_region_[plane.get()] = static_cast<int>(r);
        facet_planes_.push_back(plane);
        faces_.push_back(*facet);
        face_region_.push_back(static_cast<int>(r));
        face_facet_.push_back(1);
      }
      continue;
    }
    bool complete = true;
    for (const auto& loop : topo_.region_loops[r]) {
      for (const ChainUse& use : loop) complete &= edge_ok_[use.chain] != 0;
    }
    if (!complete) {
      result.problems.push_back({feature, "the face has an edge that could not be made"});
      fail(static_cast<int>(r), "an edge of its face could not be made");
      continue;
    }
    const bool outward = region_sense_[r] > 0;
    if (const std::optional<TopoDS_Face> cap = pole_cap(r)) {
      faces_.push_back(outward ? *cap : TopoDS::Face(cap->Reversed()));
      face_region_.push_back(static_cast<int>(r));
      face_facet_.push_back(0);
      continue;
    }
    try {
      TopoDS_Face face;
      builder.MakeFace(face, region_surfaces_[r], Precision::Confusion());
      for (const auto& loop : topo_.region_loops[r]) {
        if (std::all_of(loop.begin(), loop.end(),
                        [&](const ChainUse& use) { return collapsed_[use.chain] != 0 && !polyline_[use.chain]; }))
          continue;
        TopoDS_Wire wire;
        builder.MakeWire(wire);
        // Loops run with the face on their left seen from outside; on a surface whose normal
        // points into the part the face is built reversed, with the loop reversed.
        const int n = static_cast<int>(loop.size());
        for (int i = 0; i < n; ++i) {
          const ChainUse& use = loop[outward ? i : n - 1 - i];
          const bool forward = use.forward == outward;
          if (const auto pieces = chain_pieces_.find(use.chain); pieces != chain_pieces_.end()) {
            const std::vector<TopoDS_Edge>& along = pieces->second;  // oriented along the chain
            for (size_t k = 0; k < along.size(); ++k)
              builder.Add(wire, forward ? along[k] : TopoDS::Edge(along[along.size() - 1 - k].Reversed()));
            continue;
          }
          if (collapsed_[use.chain]) continue;
          const auto split = split_edges_.find(use.chain);
          if (split == split_edges_.end()) {
            builder.Add(wire, edges_[use.chain].Oriented(forward ? TopAbs_FORWARD : TopAbs_REVERSED));
          } else {
            for (const TopoDS_Edge& part : split->second)
              builder.Add(wire, part.Oriented(forward ? TopAbs_FORWARD : TopAbs_REVERSED));
          }
        }
        wire.Closed(Standard_True);
        builder.Add(face, wire);
      }
      ShapeFix_Edge add_pcurves;
      for (TopExp_Explorer e(face, TopAbs_EDGE); e.More(); e.Next()) {
        add_pcurves.FixAddPCurve(TopoDS::Edge(e.Current()), face, Standard_False, tol_);
      }
      // (A polyline's pieces are projected one by one, each into the period nearest the surface's.)
      if (region_winds_[r] || (bounded_[r] && region_surfaces_[r]->IsUPeriodic()))
        for (TopExp_Explorer w(face, TopAbs_WIRE); w.More(); w.Next()) continue_pcurves(TopoDS::Wire(w.Current()), face);
      faces_.push_back(outward ? face : TopoDS::Face(face.Reversed()));
      face_region_.push_back(static_cast<int>(r));
      face_facet_.push_back(0);
    } catch (const Standard_Failure& failure) {
      result.problems.push_back({feature, occt_message(failure, "the face could not be made")});
      fail(static_cast<int>(r), occt_message(failure, "its face could not be made"));
    }
  }
}

// Faces map back to features by their surface: the region's own, or for a face that healing or
// merging put on a copy (or a trimmed copy), the region's surface of that kind through points of
// the face's.
int BrepBuilder::region_of(const TopoDS_Face& face) const {
  Handle(Geom_Surface) surface = BRep_Tool::Surface(face);
  if (const auto facet = facet_region_.find(surface.get()); facet != facet_region_.end()) return facet->second;
  if (const Handle(Geom_RectangularTrimmedSurface) trimmed = Handle(Geom_RectangularTrimmedSurface)::DownCast(surface);
      !trimmed.IsNull())
    surface = trimmed->BasisSurface();  // merging bounds a periodic face's surface
  for (size_t r = 0; r < region_surfaces_.size(); ++r)
    if (region_surfaces_[r] == surface) return static_cast<int>(r);
  double u0, u1, v0, v1;
  BRepTools::UVBounds(face, u0, u1, v0, v1);
  const std::array<gp_Pnt, 3> points = {surface->Value(u0 + 0.25 * (u1 - u0), v0 + 0.25 * (v1 - v0)),
                                        surface->Value(u0 + 0.75 * (u1 - u0), v0 + 0.5 * (v1 - v0)),
                                        surface->Value(u0 + 0.5 * (u1 - u0), v0 + 0.75 * (v1 - v0))};
  for (size_t r = 0; r < region_surfaces_.size(); ++r) {
    // (A faceted region has no face on its surface: a coplanar region's face is not its.)
    if (region_surfaces_[r].IsNull() || faceted_[r] || region_surfaces_[r]->DynamicType() != surface->DynamicType()) continue;
    const bool on = std::all_of(points.begin(), points.end(), [&](const gp_Pnt& p) {
      GeomAPI_ProjectPointOnSurf projection(p, region_surfaces_[r]);
      return projection.NbPoints() > 0 && projection.LowerDistance() <= tol_;
    });
    if (on) return static_cast<int>(r);
  }
  return -1;
}

}  // namespace idealize
