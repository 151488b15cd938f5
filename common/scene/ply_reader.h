// A reader for PLY triangle and polygon meshes (the Stanford format pbrt-v4's "plymesh" shape
// names): ASCII, binary little and big endian, and any of those gzip-compressed (.ply.gz).
//
// Read: the "vertex" element's x y z (any numeric type), nx ny nz when all three are there, and
// the first complete pair of u v, s t, texture_u texture_v or texture_s texture_t; the "face"
// element's list "vertex_indices" (or "vertex_index") of any integer count and index types.
// Triangles are taken as written; a quad a b c d becomes (a b c) and (a c d), and a polygon of n
// vertices the fan (a b c), (a c d), ... of n - 2 triangles, which is right for convex polygons.
// Every other element and property ("face_indices", colours, ...) is skipped, lists too.
#pragma once

#include "common/scene/triangle_mesh.h"

#include <cstdint>
#include <string>
#include <string_view>

namespace alphorn {

// A gzip-compressed file may inflate to at most kMaxPlyInflationRatio times its own size plus
// kPlyInflationAllowance, and never beyond kMaxPlyInflatedBytes: mesh data compresses by a few
// times (binary floats by less than 2), while a crafted file (a "zip bomb") inflates by up to
// about 1000 times. Its size is measured by inflating it once without keeping anything, so a
// file beyond the cap is refused without taking memory for it.
constexpr uint64_t kMaxPlyInflationRatio = 64;
constexpr uint64_t kPlyInflationAllowance = uint64_t(64) << 20;  // 64 MiB
constexpr uint64_t kMaxPlyInflatedBytes = uint64_t(4) << 30;     // 4 GiB

// Reads the PLY file at `path` (gzip-compressed or not, told by its first bytes) into object-space
// geometry. Throws Error("`name`: problem") (or "`name`:LINE: problem" for a header line or ASCII
// data, "`name` (byte N): problem" for binary data), `name` being how messages show the file
// (the path relative to the scene, say), for a file that cannot be read, a malformed or unsupported
// header, data that ends before the header's counts do (checked against the file's size before
// anything is allocated), a value that does not parse or is not finite, a face of fewer than 3
// vertices, a vertex index out of range, or a file without faces.
TriangleGeometry readPlyFile(const std::string& path, const std::string& name);

// The same for the bytes of a PLY file (gzip-compressed or not) already in memory.
TriangleGeometry readPlyBytes(std::string_view bytes, const std::string& name);

}  // namespace alphorn
