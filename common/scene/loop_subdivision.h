// Loop subdivision of a triangle mesh (pbrt-v4's "loopsubdiv" shape): each round splits every
// triangle into four, with Loop's weights for the new and the moved vertices (and the boundary
// rules along edges of a single face); after the last round the vertices are pushed to their
// limit positions and given the limit surface's normals, as pbrt-v4 does.
#pragma once

#include "common/scene/triangle_mesh.h"

#include <cstdint>
#include <string>

namespace alphorn {

// The most triangles subdivision may make (faces * 4^levels): about 2.5 GB with the ray tracing
// structure over them. pbrt-v4's scenes subdivide meshes of thousands of triangles 1 to 3 times.
constexpr uint64_t kMaxLoopSubdivisionTriangles = uint64_t(1) << 24;

// Subdivides the mesh `levels` times (0: no split, but the vertices still go to the limit
// surface) and returns the limit mesh: positions, normals and faces, no uvs. Its first vertices
// are the input's, in their order, moved to the limit (vertices no face uses are left out); the
// vertices each round adds follow them. The weights are pbrt-v4's: an interior vertex of valence
// n keeps 1 - n*beta of itself and takes beta of each neighbour (beta = 3/16 for n = 3, else
// 3/(8n)), a boundary vertex 3/4 of itself and 1/8 of each neighbour along the boundary; a new
// vertex on an interior edge is 3/8 of each end plus 1/8 of each opposite vertex, on a boundary
// edge the midpoint. The limit position of an interior vertex weighs its neighbours by
// gamma = 1 / (n + 3/(8 beta)). A boundary vertex goes to 3/5 of itself plus 1/5 of each
// boundary neighbour, pbrt-v4's rule: the boundary rules above are those of a cubic B-spline,
// whose exact limit weights are 1/6, 2/3, 1/6, so boundary vertices land within a fraction of the
// boundary polygon's second differences of that curve, an error that shrinks fourfold with every
// level; it is kept so that meshes match pbrt's.
//
// Normals follow pbrt-v4's limit tangents, and so its orientation: they point to the side
// opposite the faces' winding normal (p1 - p0) x (p2 - p0). In pbrt the shading normal decides
// which side of a triangle is its front (for area lights and media), so a mesh subdivided here
// keeps the front pbrt gives it.
//
// Throws Error("`source`: problem") for levels < 0, output beyond kMaxLoopSubdivisionTriangles,
// no faces, a vertex index out of range, a face that uses a vertex twice, a position that is not
// finite, and a mesh that is not a consistently oriented manifold (an edge with more than two
// faces, neighbouring faces of opposite orientation, or faces meeting only at a vertex), which
// the scheme's rules are not defined for.
TriangleGeometry loopSubdivide(const Eigen::Matrix<float, 3, Eigen::Dynamic>& positions,
                               const Eigen::Matrix<uint32_t, 3, Eigen::Dynamic>& faces, int levels,
                               const std::string& source);

}  // namespace alphorn
