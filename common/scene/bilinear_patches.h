// pbrt-v4's "bilinearmesh" shape as triangles: each bilinear patch becomes two.
#pragma once

#include "common/scene/triangle_mesh.h"

#include <string>
#include <vector>

namespace alphorn {

// The patches given by `indices`, four a patch in pbrt-v4's order p00 p10 p01 p11 (the corners
// at (u, v) = (0, 0), (1, 0), (0, 1), (1, 1)), each as the triangles (p00, p10, p11) and
// (p00, p11, p01), wound so that their normal is pbrt's dp/du x dp/dv. A planar patch is exact;
// a warped (non-planar) one is approximated by the two flat halves on either side of its p00-p11
// diagonal, which differ from the curved patch by at most half the distance between the midpoints
// of its two diagonals (at its centre).
//
// Every patch gets four vertices of its own, so that it keeps the (u, v) parameterisation pbrt
// gives it: without `uvs`, its corners' (u, v) as above (as pbrt maps a patch without uvs);
// with them (one per position), the corners' uvs. `normals`, when given (one per position), are
// copied to the corners; otherwise the result has none and shading uses the flat triangles.
//
// Throws Error("`source`: problem") for no patches, an index count that is not a multiple of 4,
// an index out of range, or uvs or normals that are neither absent nor one per position.
TriangleGeometry bilinearPatchesAsTriangles(
    const Eigen::Matrix<float, 3, Eigen::Dynamic>& positions, const std::vector<uint32_t>& indices,
    const Eigen::Matrix<float, 2, Eigen::Dynamic>& uvs,
    const Eigen::Matrix<float, 3, Eigen::Dynamic>& normals, const std::string& source);

}  // namespace alphorn
