// Output of a fitted B-rep: OCCT's BRep text for FreeCAD, STEP files, triangulations.
#pragma once

#include "core/mesh.h"
#include "core/progress.h"

#include <TopoDS_Shape.hxx>

#include <string>

namespace idealize {

// The shape in OCCT's native BRep text format (FreeCAD: Part.Shape().importBrepFromString).
std::string brep_string(const TopoDS_Shape& shape);

// Writes the shape to a STEP AP214 file in millimetres, faces coloured by surface type. Throws
// std::runtime_error when the file cannot be written.
void write_step(const TopoDS_Shape& shape, const std::string& path);

// A triangulation of the shape's faces with chordal deviation at most `deflection`. Reports into
// `progress` and throws Cancelled when it is cancelled.
TriangleMesh triangulate(const TopoDS_Shape& shape, double deflection, const ProgressSpan& progress = {});

}  // namespace idealize
