#include "common/render/unit.h"

#include "common/core/error.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "common/texture/plugin_testing.h"
#include "tests/support/source_tree.h"

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
                                                            filter, sourceDirectory())));
}

// A scene loaded only to be checked (as the coordinator does at submit) has no BVH: rendering it
// is refused rather than left to give a black image.
TEST(RenderUnit, RefusesASceneLoadedOnlyToBeChecked) {
    const std::string path =
        plugin_testing::writeTempFile("checked.xml", absl::StrFormat(R"(<scene>
  <integrator type="normals"/>
  <camera type="perspective"><integer name="width" value="8"/><integer name="height" value="8"/></camera>
  <mesh type="obj"><string name="filename" value="%s/scenes/meshes/quad.obj"/></mesh>
</scene>)",
                                                                     sourceDirectory()));
    const std::shared_ptr<Scene> checked = loadScene(path, {}, {}, {}, SceneUse::Check);
    const RenderUnit unit{0, 1, Tile{0, 0, 8, 8}};
    FilmBlock block = makeUnitBlock(*checked, unit.tile);
    EXPECT_THROW(preparePasses(*checked, 1, 0, 1), Error);
    EXPECT_THROW(renderUnit(*checked, 1, unit, {}, block), Error);
    const std::shared_ptr<Scene> rendered = loadScene(path);
    EXPECT_TRUE(renderUnit(*rendered, 1, unit, preparePasses(*rendered, 1, 0, 1), block));
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

// The local renderer and a farm job cut the image alike: the tiles of makeTiles, each
// rendered into its tile grown by the scene's filter border.
TEST(TileGrid, IsTheTilesOfTheImageWithTheScenesBorder) {
    const auto scene = sceneWithFilter("grid_box.xml", R"(<rfilter type="box"/>)");
    const TileGrid grid(*scene, 3);
    EXPECT_EQ(grid.width(), 8);
    EXPECT_EQ(grid.height(), 8);
    EXPECT_EQ(grid.border(), filterBorder(*scene));
    EXPECT_EQ(grid.tiles(), makeTiles(8, 8, 3));
    const Tile& edge = grid.tiles().back();
    const FilmBlock block = grid.block(edge);
    const FilmBlock expected = unitBlock(edge, grid.border());
    EXPECT_EQ(block.x0(), expected.x0());
    EXPECT_EQ(block.y0(), expected.y0());
    EXPECT_EQ(block.width(), expected.width());
    EXPECT_EQ(block.height(), expected.height());
    EXPECT_THROW(TileGrid(0, 8, 4, 1), Error);
    EXPECT_THROW(TileGrid(8, 8, 0, 1), Error);
    EXPECT_THROW(TileGrid(8, 8, 4, -1), Error);
}

// A crop gets exactly the tiles that can splat into it: those whose grown tile shares a pixel
// with it, checked pixel by pixel. Tiles of 7 grown by 2: the first column's and row's end at 9,
// the third's start at 12, so the region [9, 12)² touches those without sharing a pixel.
TEST(TileGrid, TilesReachingAreThoseWhoseBlocksShareAPixelWithTheRegion) {
    const TileGrid grid(40, 30, 7, 2);
    for (const Tile& region :
         {Tile{0, 0, 1, 1}, Tile{9, 9, 10, 10}, Tile{12, 5, 20, 6}, Tile{39, 29, 40, 30},
          Tile{0, 0, 40, 30}, Tile{16, 16, 17, 17}, Tile{9, 9, 12, 12}}) {
        std::vector<Tile> expected;
        for (const Tile& tile : grid.tiles()) {
            const Tile grown = grownTile(tile, grid.border());
            bool shares = false;
            for (int y = region.y0; y < region.y1; ++y)
                for (int x = region.x0; x < region.x1; ++x)
                    shares =
                        shares || (x >= grown.x0 && x < grown.x1 && y >= grown.y0 && y < grown.y1);
            if (shares) expected.push_back(tile);
        }
        EXPECT_EQ(grid.tilesReaching(region), expected)
            << region.x0 << "," << region.y0 << " " << region.x1 << "," << region.y1;
        if (region.width() < grid.width()) {
            EXPECT_LT(expected.size(), grid.tiles().size());
        }
    }
}

}  // namespace
}  // namespace alphorn
