#include "common/render/unit.h"

#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "common/texture/plugin_testing.h"

#include <absl/strings/str_format.h>
#include <gtest/gtest.h>

namespace alphorn {
namespace {

std::shared_ptr<Scene> sceneWithFilter(const std::string& name, const std::string& filter) {
    return loadScene(
        plugin_testing::writeTempFile(name, absl::StrFormat(R"(<scene>
  <integrator type="normals"/>
  <camera type="perspective">
    <integer name="width" value="8"/><integer name="height" value="8"/>
    %s
  </camera>
  <mesh type="obj"><string name="filename" value="%s/scenes/meshes/quad.obj"/></mesh>
</scene>)",
                                                            filter, ALPHORN_SOURCE_DIR)));
}

// The border is the filter's radius plus half a pixel (a pixel's centre sits half a pixel in
// from its edge), rounded up: every pixel a sample in the tile can splat into.
TEST(UnitBlock, FilterBorderCoversTheFilterRadius) {
    EXPECT_EQ(filterBorder(*sceneWithFilter("box.xml", R"(<rfilter type="box"/>)")), 1);
    EXPECT_EQ(filterBorder(*sceneWithFilter("gaussian.xml", "")), 3);  // radius 2, the default
    EXPECT_EQ(
        filterBorder(*sceneWithFilter(
            "wide_box.xml", R"(<rfilter type="box"><float name="radius" value="1.2"/></rfilter>)")),
        2);
}

TEST(UnitBlock, IsTheTileGrownByTheBorderOnEachSide) {
    const FilmBlock block = unitBlock(Tile{16, 32, 24, 36}, 3);
    EXPECT_EQ(block.x0(), 13);
    EXPECT_EQ(block.y0(), 29);
    EXPECT_EQ(block.width(), 8 + 6);
    EXPECT_EQ(block.height(), 4 + 6);
}

// What a worker renders into (makeUnitBlock, from the scene) is what the coordinator expects
// (unitBlock, from the border it stored at submission).
TEST(UnitBlock, MakeUnitBlockIsUnitBlockWithTheScenesBorder) {
    const auto scene = sceneWithFilter("mitchell.xml", R"(<rfilter type="mitchell"/>)");
    const Tile tile{0, 8, 5, 11};
    const FilmBlock fromScene = makeUnitBlock(*scene, tile);
    const FilmBlock fromBorder = unitBlock(tile, filterBorder(*scene));
    EXPECT_EQ(fromScene.x0(), fromBorder.x0());
    EXPECT_EQ(fromScene.y0(), fromBorder.y0());
    EXPECT_EQ(fromScene.width(), fromBorder.width());
    EXPECT_EQ(fromScene.height(), fromBorder.height());
    EXPECT_GT(fromScene.width(), tile.width());
}

}  // namespace
}  // namespace alphorn
