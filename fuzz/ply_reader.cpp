// Fuzzes the PLY reader (<mesh type="ply">, and pbrt's "plymesh" through the same reader):
// arbitrary bytes as the file, plain or gzip-compressed; the geometry it accepts is built into a
// mesh, put in an Embree BVH, hit by a ray and sampled, which reads back every index and
// attribute, and a small one is also Loop-subdivided once, which walks its connectivity.
#include "common/scene/ply_reader.h"
#include "common/core/error.h"
#include "common/scene/loop_subdivision.h"
#include "common/scene/triangle_mesh.h"
#include "fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    alphorn::fuzz::silenceWarnings();
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace alphorn;
    TriangleGeometry geometry;
    try {
        geometry = readPlyBytes(fuzz::asText(data, size), "fuzz.ply");
    } catch (const Error&) {
        return 0;
    }
    // Subdivision's work grows fourfold a level: one level of a small mesh is enough to reach
    // every rule.
    if (geometry.faces.cols() <= 2000) {
        try {
            loopSubdivide(geometry.positions, geometry.faces, 1, "fuzz.ply");
        } catch (const Error&) {
        }
    }
    std::shared_ptr<Mesh> mesh;
    try {
        mesh = std::make_shared<TriangleMesh>(std::move(geometry), "fuzz.ply", "fuzz");
        mesh->activate();
    } catch (const Error&) {
        return 0;
    }
    fuzz::traceAndSample(mesh);
    return 0;
}
