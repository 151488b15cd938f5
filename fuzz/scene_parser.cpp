// Fuzzes the Nori XML scene loader: parseSceneFile() on arbitrary bytes, through object creation
// and activation, so absurd parameter values reach every plugin. The scene is written into a
// private directory beside small real meshes and textures it may refer to by name (see the
// corpus). Inputs whose <string> values contain '/' are skipped: they could name files outside
// that directory (/dev/zero, large system files) and make the run depend on the machine.
#include "common/core/error.h"
#include "common/core/image.h"
#include "common/scene/parser.h"
#include "fuzz/fuzz_support.h"
#include "tests/support/source_tree.h"

#include <pugixml.hpp>

#include <cstring>

namespace {

using namespace alphorn;

// Files the corpus scenes refer to, copied into the scratch directory under their base names.
constexpr const char* kFixtures[] = {
    "scenes/meshes/quad.obj",
    "scenes/meshes/cube.obj",
    "scenes/meshes/triangle.obj",
    "tests/statistical/meshes/open_box.obj",
    "scenes/stage/textures/swiss_flag.png",
};

bool namesFileOutsideScratch(const pugi::xml_node& node) {
    for (const pugi::xml_node& child : node.children()) {
        if (std::strcmp(child.name(), "string") == 0 &&
            std::strchr(child.attribute("value").value(), '/'))
            return true;
        if (namesFileOutsideScratch(child)) return true;
    }
    return false;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    fuzz::silenceWarnings();
    namespace fs = std::filesystem;
    for (const char* fixture : kFixtures)
        fs::copy_file(fs::path(alphorn::sourceDirectory()) / fixture,
                      fs::path(fuzz::scratchDirectory()) / fs::path(fixture).filename(),
                      fs::copy_options::overwrite_existing);
    Image image(3, 2);
    for (size_t i = 0; i < image.rgb.size(); ++i) image.rgb[i] = 0.1f * float(i);
    writeEXR(fuzz::scratchDirectory() + "/image.exr", image);
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    pugi::xml_document document;
    if (document.load_buffer(data, size) && namesFileOutsideScratch(document)) return -1;
    const std::string path = fuzz::scratchDirectory() + "/scene.xml";
    fuzz::writeFile(path, fuzz::asText(data, size));
    try {
        parseSceneFile(path);
    } catch (const Error&) {
        // A clear error is the right answer to a broken scene; anything else escapes and is
        // reported by libFuzzer as a crash.
    }
    return 0;
}
