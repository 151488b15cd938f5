// Fuzzes the pbrt-v4 scene front end: parseSceneFile() on arbitrary bytes written as a .pbrt
// file, through tokens, the parsed scene and object creation, so absurd parameters reach every
// plugin the front end makes. The scene is confined to its scratch directory (as a farm job is
// to its bundle), so no input can make it read the machine's other files; the seeds include
// each other and a small PLY mesh there.
#include "common/core/error.h"
#include "common/scene/parser.h"
#include "fuzz/fuzz_support.h"

namespace {

// A PLY file the seeds' plymesh shapes name.
constexpr const char* kTrianglePly =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
    "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    alphorn::fuzz::silenceWarnings();
    alphorn::fuzz::writeFile(alphorn::fuzz::scratchDirectory() + "/triangle.ply", kTrianglePly);
    alphorn::fuzz::writeFile(alphorn::fuzz::scratchDirectory() + "/included.pbrt",
                             "Shape \"sphere\" \"float radius\" 0.5\n");
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace alphorn;
    const std::string path = fuzz::scratchDirectory() + "/scene.pbrt";
    fuzz::writeFile(path, fuzz::asText(data, size));
    FileReferencePolicy policy;
    policy.confinementRoot = fuzz::scratchDirectory();
    try {
        parseSceneFile(path, policy);
    } catch (const Error&) {
        // A clear error is the right answer to a broken scene; anything else escapes and is
        // reported by libFuzzer as a crash.
    }
    return 0;
}
