// pbrt-v4's quadric shapes (sphere, disk, cylinder) as triangle meshes in object space, with the
// exact surface's normals at the vertices and pbrt's (u, v) parameterisation: u = phi / phimax
// around z; v from zmin (0) to zmax (1) on a sphere (in its polar angle) and a cylinder, from the
// outer radius (0) to the inner one (1) on a disk. Normals point outward (away from the axis or
// centre; +z on a disk), as pbrt's before ReverseOrientation, and the triangles are wound to
// agree with them.
//
// Each surface is cut into steps of at most kQuadricStepRadians in phi and, on a sphere, in the
// polar angle. A triangle then lies within about r * step^2 / 4 = 0.000625 r of the curved
// surface (r the radius), less than 0.1% of the radius, and the triangles' area is
// within 0.1% of the exact surface's. Measured (the tests check the bounds): a full sphere is 63
// x 126 cells, 15624 triangles, lying at most 0.062% of the radius inside the sphere, with 0.052%
// less area; a full disk's rim and a cylinder's cross-section are 126-gons, 0.031% of the radius
// inside the circle at the chords' middles, with 0.041% and 0.010% less area. The phi seam and
// the poles are duplicated vertices, one for each u, so that uvs are continuous within every
// triangle; the triangles that would be degenerate at a pole or a disk's centre are left out.
#pragma once

#include "common/scene/triangle_mesh.h"

namespace alphorn {

constexpr double kQuadricStepRadians = 0.05;

// As pbrt-v4 reads them: zmin and zmax are put in order and clamped to [-radius, radius], and
// phimax (degrees) is clamped to [0, 360]. The errors name the shape and the parameter as pbrt
// spells it ("sphere: zmin must be finite, got nan"), for the caller to prefix with where the
// shape was written. Throws Error for a radius that is not finite and
// positive, values that are not finite, and a surface of no area (zmin = zmax, phimax = 0).
TriangleGeometry tessellateSphere(float radius, float zmin, float zmax, float phimaxDegrees);

// A disk (or annulus) at z = height between innerRadius and radius. Throws Error unless
// 0 <= innerRadius < radius, all finite, and for phimax = 0.
TriangleGeometry tessellateDisk(float height, float radius, float innerRadius, float phimaxDegrees);

// A cylinder about z from zmin to zmax (put in order). Throws Error for a radius that is not
// finite and positive, values that are not finite, and zmin = zmax or phimax = 0.
TriangleGeometry tessellateCylinder(float radius, float zmin, float zmax, float phimaxDegrees);

}  // namespace alphorn
