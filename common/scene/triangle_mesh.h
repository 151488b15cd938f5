// Triangle meshes made from geometry in memory rather than read from an OBJ file: what the PLY
// reader, Loop subdivision, bilinear patches and the tessellated quadrics produce, and what a
// scene front end builds a Mesh from.
#pragma once

#include "common/core/transform.h"
#include "common/scene/mesh.h"

#include <string>

namespace alphorn {

// A triangle mesh's arrays, in object or world space as whoever holds it says. Triangles are
// counter-clockwise seen from the side their winding normal (p1 - p0) x (p2 - p0) points to.
struct TriangleGeometry {
    Eigen::Matrix<float, 3, Eigen::Dynamic> positions;
    Eigen::Matrix<float, 3, Eigen::Dynamic> normals;  // empty, or one per vertex
    Eigen::Matrix<float, 2, Eigen::Dynamic> uvs;      // empty, or one per vertex
    Eigen::Matrix<uint32_t, 3, Eigen::Dynamic> faces;
};

// Embree refuses (asserts on) rays whose origin has a coordinate beyond about 1.8e18, and rays
// leave from surface points: every vertex stays within this bound (the OBJ loader's as well).
constexpr float kMaxMeshCoordinate = 1e15f;

// Transforms the positions by `toWorld` and the normals by its inverse transpose, normalised,
// in place: the same arithmetic as <mesh type="obj"> applies to its file's vertices, so that a
// mesh gives the same bytes whichever file it came from. A zero normal stays zero (shading falls
// back to the triangle's own normal there).
void transformGeometry(TriangleGeometry& geometry, const Transform& toWorld);

// Turns every triangle over (swaps its second and third corners), which reverses its winding
// normal and leaves the vertex normals alone. A transform that mirrors space (negative
// determinant) turns the winding normals of the triangles it moves inside out; pbrt keeps the
// object's front under it (and swaps it under ReverseOrientation), which a front end gets by
// turning the triangles over where pbrt would flip the normal.
void flipWinding(TriangleGeometry& geometry);

// Checks geometry before a mesh is built from it and throws Error("`source`: problem") for the
// first problem: no triangle, a vertex index out of range, a position that is not finite or lies
// beyond +-kMaxMeshCoordinate, normals or uvs that are neither absent nor one per vertex, or a
// normal or uv that is not finite. Degenerate (zero-area) triangles pass: the mesh handles them.
void checkGeometry(const TriangleGeometry& geometry, const std::string& source);

// A Mesh made from geometry in memory. `source` names where it was written, for messages
// ("scene.pbrt:12:1 (Shape \"trianglemesh\")"); `name` is what toString shows. The geometry is
// checked (checkGeometry) and taken as is: positions and normals as given (in world space), uvs
// as given. Like every mesh it takes a bsdf, an emitter and inside/outside media through
// addChild, and the caller calls activate() once they are added.
class TriangleMesh : public Mesh {
  public:
    TriangleMesh(TriangleGeometry geometry, std::string source, std::string name = "");
};

}  // namespace alphorn
