// The textured-albedo enclosure: a diffuse plane with a checkerboard albedo inside a black box
// that emits radiance 1 everywhere. Each BSDF-sampled ray from the plane hits the box, so
// direct_mats sees exactly albedo(uv) * 1 on the plane -- with zero variance -- and exactly 1
// on the walls. A texture looked up at the wrong uv, or not at all, shows up as other values.
#include "common/render/local_render.h"
#include "common/scene/scene.h"
#include "common/texture/plugin_testing.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>

namespace alphorn {
namespace {

TEST(TexturedAlbedo, EnclosureShowsExactlyTheAlbedo) {
    if (!ObjectFactory::has(ObjectKind::Integrator, "direct_mats") ||
        !ObjectFactory::has(ObjectKind::Emitter, "area"))
        GTEST_SKIP() << "needs direct_mats and the area emitter";
    const std::string meshes = sourcePath("scenes/meshes/");
    const std::string xml = absl::StrFormat(R"(<scene>
  <integrator type="direct_mats"/>
  <camera type="perspective">
    <transform name="toWorld"><lookat origin="0, 0.9, 0" target="0, -0.5, 0" up="0, 0, -1"/></transform>
    <float name="fov" value="60"/><integer name="width" value="32"/><integer name="height" value="32"/>
    <rfilter type="box"/>
  </camera>
  <mesh type="obj">
    <string name="filename" value="%scube_inward.obj"/>
    <bsdf type="diffuse"><color name="albedo" value="0"/></bsdf>
    <emitter type="area"><color name="radiance" value="1"/></emitter>
  </mesh>
  <mesh type="obj">
    <string name="filename" value="%squad.obj"/>
    <transform name="toWorld"><scale value="0.6, 1, 0.6"/><translate value="0, -0.5, 0"/></transform>
    <bsdf type="diffuse">
      <texture type="checkerboard2d" name="albedo">
        <color name="color0" value="0.8, 0.1, 0.1"/><color name="color1" value="0.1, 0.3, 0.9"/>
      </texture>
    </bsdf>
  </mesh>
</scene>)",
                                            meshes, meshes);
    auto scene = loadScene(plugin_testing::writeTempFile("textured_albedo.xml", xml));
    RenderSettings settings;
    settings.passes = 4;
    const Image image = resolveImage(renderLocal(*scene, settings), 32, 32);
    const Color3f c0(0.8f, 0.1f, 0.1f), c1(0.1f, 0.3f, 0.9f), wall(1.0f);
    int n0 = 0, n1 = 0, nWall = 0;
    // Quadrant of the plane at uv (0, 0) -- world x < 0, z < 0 -- is colour0. Looking down
    // with up = -z, image left is world -x and image top is world -z.
    Color3f topLeft = image.get(11, 11), topRight = image.get(20, 11);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(topLeft[c], c0[c], 1e-5f);
        EXPECT_NEAR(topRight[c], c1[c], 1e-5f);
    }
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 32; ++x) {
            const Color3f v = image.get(x, y);
            n0 += (v - c0).abs().maxCoeff() < 1e-5f;
            n1 += (v - c1).abs().maxCoeff() < 1e-5f;
            nWall += (v - wall).abs().maxCoeff() < 1e-5f;
        }
    EXPECT_GT(n0, 150);
    EXPECT_GT(n1, 150);
    EXPECT_GT(nWall, 150);
    // Only pixels straddling an edge may be mixtures.
    EXPECT_GT(n0 + n1 + nWall, 32 * 32 - 200);
}

}  // namespace
}  // namespace alphorn
