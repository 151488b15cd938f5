// Fuzzes the Wavefront OBJ loader (<mesh type="obj">, tinyobjloader underneath): arbitrary bytes
// as the OBJ file, then the mesh is activated, put in an Embree BVH, hit by a ray and sampled,
// which reads back every index and attribute the loader accepted.
#include "common/core/error.h"
#include "common/core/properties.h"
#include "fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    alphorn::fuzz::silenceWarnings();
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace alphorn;
    const std::string path = fuzz::scratchDirectory() + "/mesh.obj";
    fuzz::writeFile(path, fuzz::asText(data, size));
    PropertyList props("fuzz (mesh type=\"obj\")");
    props.setString("filename", path);
    std::shared_ptr<Mesh> mesh;
    try {
        mesh =
            std::static_pointer_cast<Mesh>(ObjectFactory::create(ObjectKind::Mesh, "obj", props));
        mesh->activate();
    } catch (const Error&) {
        return 0;
    }
    fuzz::traceAndSample(mesh);
    return 0;
}
