// Closed shells into solids: one solid per body, with the shells nested inside a body as its
// voids. A mesh may hold several bodies (an assembly exported as one file), or two sheets that
// touch along an edge, which the facets keep apart (facets.h).
#pragma once

#include <TopoDS_Face.hxx>
#include <TopoDS_Shape.hxx>
#include <TopoDS_Shell.hxx>

#include <vector>

namespace idealize {

// The faces grouped into shells of faces connected through shared edges, in the order of each
// shell's first face.
std::vector<TopoDS_Shell> connected_shells(const std::vector<TopoDS_Face>& faces);

// One solid per outer shell (oriented outwards), each with the shells that lie inside it as voids;
// a compound of them where there are several bodies. Every shell must be closed.
TopoDS_Shape solids_from_shells(const std::vector<TopoDS_Shell>& shells);

}  // namespace idealize
