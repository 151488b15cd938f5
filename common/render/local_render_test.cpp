#include "common/render/local_render.h"

#include "common/core/error.h"
#include "common/core/system_memory.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>

namespace alphorn {
namespace {

std::shared_ptr<Scene> pathTracedScene(int width, int height) {
    SceneOverrides overrides;
    overrides.imageSize = Vector2i(width, height);
    return loadScene(sourcePath("tests/integration/scenes/farm_path.xml"), {}, overrides);
}

// A film beyond the memory limit is refused before it is allocated, with the size it would need;
// one that fits exactly renders. (A path-traced film keeps 128 bytes of sums per pixel: the
// totals and the odd passes' half.)
TEST(RenderLocal, RefusesAFilmLargerThanTheMemoryLimitWithItsSize) {
    const auto scene = pathTracedScene(40, 30);
    RenderSettings settings;
    settings.maxFilmBytes = 40 * 30 * 128 - 1;
    try {
        renderLocal(*scene, settings);
        FAIL() << "a film over the limit was rendered";
    } catch (const Error& error) {
        const std::string message = error.what();
        EXPECT_NE(message.find("40x30"), std::string::npos) << message;
        EXPECT_NE(message.find("128 bytes of sums per pixel"), std::string::npos) << message;
        EXPECT_NE(message.find("the limit of"), std::string::npos) << message;
    }
    settings.maxFilmBytes = 40 * 30 * 128;
    const FilmBlock film = renderLocal(*scene, settings);
    EXPECT_EQ(film.width(), 40);
    EXPECT_GT(film.at(20, 15).weight, 0);
}

// Without a limit the machine's memory is the limit: the largest image the scene format allows
// (16384 x 16384, 32 GiB of sums) is refused wherever it cannot fit. (Where it could, rendering it
// here would take hours: skipped.)
TEST(RenderLocal, RefusesAFilmLargerThanTheMachinesMemory) {
    const auto scene = pathTracedScene(16384, 16384);
    const uint64_t filmBytes = uint64_t(16384) * 16384 * 128;
    if (physicalMemoryBytes() >= filmBytes)
        GTEST_SKIP() << "this machine could hold the film; rendering it here would take hours";
    RenderSettings settings;
    EXPECT_THROW(renderLocal(*scene, settings), Error);
}

}  // namespace
}  // namespace alphorn
