#include "common/texture/texture.h"
#include "common/bsdf/bsdf.h"
#include "common/core/image.h"
#include "common/core/rng.h"
#include "common/texture/plugin_testing.h"

#include <gtest/gtest.h>

namespace alphorn {
namespace {

using plugin_testing::expectParseError;
using plugin_testing::parseAs;
using plugin_testing::writeTempFile;

std::shared_ptr<Texture> tex(const std::string& xml) {
    return parseAs<Texture>("texture.xml", xml);
}

void expectColor(const Color3f& actual, const Color3f& expected, float tolerance = 1e-6f) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(actual[c], expected[c], tolerance) << "channel " << c;
}

const Point3f kNoPoint = Point3f::Zero();
const Point2f kNoUV = Point2f::Zero();

// Every value stays within the texture's declared bounds (what media majorants rely on).
void expectWithinBounds(const Texture& t, float uvRange = 5.0f, float pRange = 10.0f) {
    Rng rng(1, 0, 0, StreamPurpose::Test);
    const Color3f lo = t.lowerBound(), hi = t.upperBound();
    for (int i = 0; i < 20000; ++i) {
        const Point2f uv(uvRange * (2 * rng.nextFloat() - 1), uvRange * (2 * rng.nextFloat() - 1));
        const Point3f p(pRange * (2 * rng.nextFloat() - 1), pRange * (2 * rng.nextFloat() - 1),
                        pRange * (2 * rng.nextFloat() - 1));
        const Color3f v = t.eval(uv, p);
        ASSERT_TRUE(v.allFinite());
        for (int c = 0; c < 3; ++c) {
            ASSERT_GE(v[c], lo[c]) << t.toString();
            ASSERT_LE(v[c], hi[c]) << t.toString();
        }
    }
}

TEST(Texture, Constant) {
    auto t =
        tex(R"(<texture type="constant"><color name="value" value="0.1, 0.2, 0.3"/></texture>)");
    expectColor(t->eval(Point2f(0.3f, 0.9f), Point3f(4, 5, 6)), Color3f(0.1f, 0.2f, 0.3f));
    EXPECT_TRUE(t->is3D());
    expectColor(t->upperBound(), Color3f(0.1f, 0.2f, 0.3f));
}

TEST(Texture, UVShowsMappedCoordinates) {
    auto t = tex(R"(<texture type="uv"/>)");
    expectColor(t->eval(Point2f(0.25f, 0.75f), kNoPoint), Color3f(0.25f, 0.75f, 0.0f));
    auto scaled = tex(R"(<texture type="uv"><float name="uscale" value="2"/>
      <float name="voffset" value="0.5"/></texture>)");
    expectColor(scaled->eval(Point2f(0.375f, 0.25f), kNoPoint), Color3f(0.75f, 0.75f, 0.0f));
    expectColor(scaled->eval(Point2f(0.625f, 0.75f), kNoPoint), Color3f(0.25f, 0.25f, 0.0f));
    EXPECT_FALSE(t->is3D());
    expectWithinBounds(*scaled);
}

// The uv mapping only multiplies and adds: a zero scale holds the lookup at the offset (the
// texture is constant along that axis) and a negative one mirrors it; both render. Only NaN and
// inf are refused.
TEST(Texture, ZeroAndNegativeUVScalesRender) {
    auto held = tex(R"(<texture type="uv"><float name="uscale" value="0"/>
      <float name="uoffset" value="0.25"/><float name="vscale" value="-1"/></texture>)");
    for (const Point2f& uv : {Point2f(0, 0.25f), Point2f(0.7f, 0.25f), Point2f(13.0f, 0.25f)})
        expectColor(held->eval(uv, kNoPoint), Color3f(0.25f, 0.75f, 0.0f));
    expectWithinBounds(*held);
    auto flat = tex(R"(<texture type="checkerboard2d"><float name="uscale" value="0"/>
      <float name="vscale" value="0"/><color name="color0" value="0.9"/></texture>)");
    for (const Point2f& uv : {Point2f(0.3f, 0.9f), Point2f(-5.0f, 7.0f)})
        expectColor(flat->eval(uv, kNoPoint), Color3f(0.9f));
    for (const char* bad : {"nan", "inf"})
        expectParseError("bad_uscale.xml",
                         std::string(R"(<texture type="uv"><float name="uscale" value=")") + bad +
                             R"("/></texture>)",
                         1, "uscale and vscale must be finite");
}

TEST(Texture, Checkerboard2DOrientation) {
    // Scales differ in u and v, so swapping u and v would change the answers.
    auto t = tex(R"(<texture type="checkerboard2d">
      <color name="color0" value="1, 0, 0"/><color name="color1" value="0, 0, 1"/>
      <float name="uscale" value="2"/><float name="vscale" value="1"/>
      <float name="uoffset" value="0.1"/></texture>)");
    const Color3f c0(1, 0, 0), c1(0, 0, 1);
    // u' = 2u + 0.1, v' = v; colour0 where floor(2u') + floor(2v') is even.
    expectColor(t->eval(Point2f(0.1f, 0.1f), kNoPoint), c0);  // 2u' = 0.6, 2v' = 0.2
    expectColor(t->eval(Point2f(0.3f, 0.1f), kNoPoint), c1);  // 2u' = 1.4
    expectColor(t->eval(Point2f(0.1f, 0.3f), kNoPoint), c0);  // 2v' = 0.6
    expectColor(t->eval(Point2f(0.1f, 0.6f), kNoPoint), c1);  // 2v' = 1.2
    expectColor(t->eval(Point2f(0.3f, 0.6f), kNoPoint), c0);
    expectColor(t->eval(Point2f(-0.1f, 0.1f), kNoPoint), c1);  // 2u' = -0.2: cell -1
    expectWithinBounds(*t);
}

TEST(Texture, Checkerboard3DOrientation) {
    // Cubes of side 0.5, the lattice origin moved to x = 0.25.
    auto t = tex(R"(<texture type="checkerboard3d">
      <color name="color0" value="1, 0, 0"/><color name="color1" value="0, 0, 1"/>
      <float name="scale" value="0.5"/>
      <transform name="toWorld"><translate value="0.25, 0, 0"/></transform></texture>)");
    const Color3f c0(1, 0, 0), c1(0, 0, 1);
    expectColor(t->eval(kNoUV, Point3f(0.3f, 0.1f, 0.1f)), c0);
    expectColor(t->eval(kNoUV, Point3f(0.2f, 0.1f, 0.1f)), c1);  // x_local < 0
    expectColor(t->eval(kNoUV, Point3f(0.8f, 0.1f, 0.1f)), c1);  // x_local = 0.55
    expectColor(t->eval(kNoUV, Point3f(0.3f, 0.6f, 0.1f)), c1);
    expectColor(t->eval(kNoUV, Point3f(0.3f, 0.1f, 0.6f)), c1);
    expectColor(t->eval(kNoUV, Point3f(0.3f, 0.6f, 0.6f)), c0);
    // uv is ignored.
    expectColor(t->eval(Point2f(0.7f, 0.2f), Point3f(0.3f, 0.1f, 0.1f)), c0);
    EXPECT_TRUE(t->is3D());
    expectWithinBounds(*t);
}

TEST(Texture, Exponential3DFallsOffAlongLocalZ) {
    // Local +z is rotated onto world +x, and the ramp starts at world x = 1.
    auto t = tex(R"(<texture type="exponential3d">
      <color name="color0" value="1, 0, 0"/><color name="color1" value="0, 0.5, 1"/>
      <float name="falloff" value="2"/>
      <transform name="toWorld"><rotate axis="0, 1, 0" angle="90"/><translate value="1, 0, 0"/></transform>
    </texture>)");
    const Color3f c0(1, 0, 0), c1(0, 0.5f, 1);
    auto expected = [&](float h) { return Color3f(c1 + (c0 - c1) * std::exp(-2.0f * h)); };
    expectColor(t->eval(kNoUV, Point3f(1.0f, 3.0f, -2.0f)), c0, 1e-5f);
    expectColor(t->eval(kNoUV, Point3f(1.5f, 0.0f, 0.0f)), expected(0.5f), 1e-5f);
    expectColor(t->eval(kNoUV, Point3f(2.0f, 7.0f, 1.0f)), expected(1.0f), 1e-5f);
    expectColor(t->eval(kNoUV, Point3f(0.2f, 0.0f, 0.0f)), c0, 1e-5f);  // below the start
    expectColor(t->eval(kNoUV, Point3f(40.0f, 0.0f, 0.0f)), c1, 1e-5f);
    EXPECT_TRUE(t->is3D());
    expectWithinBounds(*t);
}

TEST(Texture, Perlin3DIsDeterministicSmoothAndBounded) {
    const std::string xml = R"(<texture type="perlin3d">
      <float name="frequency" value="1"/><integer name="octaves" value="3"/>
      <color name="color0" value="0, 0, 0"/><color name="color1" value="2, 4, 6"/>
      <integer name="seed" value="%d"/></texture>)";
    auto a = tex(absl::StrFormat(xml.c_str(), 3)), b = tex(absl::StrFormat(xml.c_str(), 3));
    auto c = tex(absl::StrFormat(xml.c_str(), 4));
    // Gradient noise is zero on the integer lattice at every octave (lacunarity 2): the middle.
    expectColor(a->eval(kNoUV, Point3f(2, -3, 5)), Color3f(1, 2, 3), 1e-5f);
    Rng rng(5, 0, 0, StreamPurpose::Test);
    int differentSeed = 0, variesAlongZ = 0;
    double sum = 0.0, sum2 = 0.0;
    const int n = 4000;
    for (int i = 0; i < n; ++i) {
        const Point3f p(10 * rng.nextFloat(), 10 * rng.nextFloat(), 10 * rng.nextFloat());
        const Color3f va = a->eval(kNoUV, p);
        EXPECT_EQ(va.r(), b->eval(kNoUV, p).r());
        // Grey ramp: the channels move together.
        EXPECT_NEAR(va.g(), 2.0f * va.r(), 1e-5f);
        if (std::abs(c->eval(kNoUV, p).r() - va.r()) > 1e-3f) ++differentSeed;
        // Continuity: a small step changes the value a little (noise gradient is bounded).
        const float step = 1e-3f;
        EXPECT_LT(std::abs(a->eval(kNoUV, p + Vector3f(step, 0, 0)).r() - va.r()), 0.02f);
        if (std::abs(a->eval(kNoUV, p + Vector3f(0, 0, 0.3f)).r() - va.r()) > 1e-2f) ++variesAlongZ;
        sum += va.r();
        sum2 += va.r() * va.r();
    }
    EXPECT_GT(differentSeed, n * 9 / 10);
    EXPECT_GT(variesAlongZ, n * 8 / 10);  // a real 3D noise, not a 2D one extruded along z
    const double mean = sum / n, var = sum2 / n - mean * mean;
    EXPECT_NEAR(mean, 1.0, 0.08);  // symmetric around the middle of the range
    EXPECT_GT(var, 0.01);          // and not flat
    EXPECT_TRUE(a->is3D());
    expectWithinBounds(*a);
    auto grey = tex(
        R"(<texture type="perlin3d"><float name="min" value="0.5"/><float name="max" value="3"/></texture>)");
    expectColor(grey->lowerBound(), Color3f(0.5f));
    expectColor(grey->upperBound(), Color3f(3.0f));
    expectWithinBounds(*grey);
}

TEST(Texture, BitmapEXRLookupOrientationAndWrap) {
    // A 3 x 2 image with a distinct value per texel: red = column, green = row.
    Image image(3, 2);
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 3; ++x) image.set(x, y, Color3f(float(x), float(y), 0.5f));
    const std::string path = (plugin_testing::processTempDir() / "bitmap_test.exr").string();
    writeEXR(path, image);
    auto make = [&](const std::string& wrap) {
        return tex(absl::StrFormat(R"(<texture type="bitmap"><string name="filename" value="%s"/>
          <string name="wrapMode" value="%s"/></texture>)",
                                   path, wrap));
    };
    auto t = make("repeat");
    // Texel (i, j) sits at u = (i + 0.5) / 3, v = 1 - (j + 0.5) / 2: row 0 is the top (v high).
    for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 3; ++i)
            expectColor(t->eval(Point2f((i + 0.5f) / 3, 1.0f - (j + 0.5f) / 2), kNoPoint),
                        Color3f(float(i), float(j), 0.5f), 1e-5f);
    // Bilinear: halfway between columns 0 and 1 of the top row.
    expectColor(t->eval(Point2f(1.0f / 3, 0.75f), kNoPoint), Color3f(0.5f, 0.0f, 0.5f), 1e-5f);
    // Repeat: one period to the right is the same; the left edge blends column 2 and 0.
    expectColor(t->eval(Point2f(1.0f + 0.5f / 3, 0.75f), kNoPoint), Color3f(0, 0, 0.5f), 1e-5f);
    expectColor(t->eval(Point2f(0.0f, 0.75f), kNoPoint), Color3f(1.0f, 0, 0.5f), 1e-5f);
    expectColor(make("clamp")->eval(Point2f(-2.0f, 0.75f), kNoPoint), Color3f(0, 0, 0.5f), 1e-5f);
    expectColor(make("clamp")->eval(Point2f(0.0f, 0.75f), kNoPoint), Color3f(0, 0, 0.5f), 1e-5f);
    // Mirror: just past the right edge reflects back onto column 2, then 1.
    expectColor(make("mirror")->eval(Point2f(1.0f + 1.5f / 3, 0.75f), kNoPoint),
                Color3f(1.0f, 0, 0.5f), 1e-5f);
    expectColor(t->lowerBound(), Color3f(0, 0, 0.5f));
    expectColor(t->upperBound(), Color3f(2, 1, 0.5f));
    expectWithinBounds(*t);
    expectWithinBounds(*make("mirror"));
}

TEST(Texture, BitmapPNGDecodesSRGBUnlessRaw) {
    Image image(2, 1);
    image.set(0, 0, Color3f(0.2f, 0.5f, 1.0f));
    image.set(1, 0, Color3f(0.0f, 0.05f, 0.7f));
    const std::string path = (plugin_testing::processTempDir() / "bitmap_test.png").string();
    writePNG(path, image);
    auto srgb = tex(absl::StrFormat(
        R"(<texture type="bitmap"><string name="filename" value="%s"/></texture>)", path));
    auto raw = tex(absl::StrFormat(R"(<texture type="bitmap"><string name="filename" value="%s"/>
      <boolean name="raw" value="true"/></texture>)",
                                   path));
    const Point2f texel0(0.25f, 0.5f);
    // 8-bit sRGB keeps linear values to within a fraction of a percent here.
    expectColor(srgb->eval(texel0, kNoPoint), Color3f(0.2f, 0.5f, 1.0f), 4e-3f);
    // Raw gives the stored bytes / 255, i.e. the sRGB encoding of the values.
    const Color3f encoded = Color3f(0.2f, 0.5f, 1.0f).toSRGB();
    for (int c = 0; c < 3; ++c)
        EXPECT_FLOAT_EQ(raw->eval(texel0, kNoPoint)[c], std::round(encoded[c] * 255.0f) / 255.0f);
}

TEST(Texture, CombinationSumProductMixAndBounds) {
    auto sum = tex(R"(<texture type="combination"><string name="operation" value="sum"/>
      <texture type="constant" name="a"><color name="value" value="0.1, 0.2, 0.3"/></texture>
      <texture type="checkerboard2d" name="b"><color name="color0" value="1"/><color name="color1" value="0"/></texture>
    </texture>)");
    expectColor(sum->eval(Point2f(0.1f, 0.1f), kNoPoint), Color3f(1.1f, 1.2f, 1.3f));
    expectColor(sum->eval(Point2f(0.6f, 0.1f), kNoPoint), Color3f(0.1f, 0.2f, 0.3f));
    expectColor(sum->upperBound(), Color3f(1.1f, 1.2f, 1.3f));
    EXPECT_FALSE(sum->is3D());

    // Signed operands: the product's bounds come from the corner products.
    auto product = tex(R"(<texture type="combination"><string name="operation" value="product"/>
      <texture type="perlin3d"><float name="min" value="-2"/><float name="max" value="1"/></texture>
      <texture type="checkerboard3d"><color name="color0" value="-3"/><color name="color1" value="0.5"/></texture>
    </texture>)");
    expectColor(product->lowerBound(), Color3f(-3.0f));
    expectColor(product->upperBound(), Color3f(6.0f));
    EXPECT_TRUE(product->is3D());
    expectWithinBounds(*product);
    auto perlin = tex(
        R"(<texture type="perlin3d"><float name="min" value="-2"/><float name="max" value="1"/></texture>)");
    const Point3f inside0(0.3f, 0.2f, 0.1f), inside1(1.3f, 0.2f, 0.1f);  // color0 / color1 cubes
    EXPECT_FLOAT_EQ(product->eval(kNoUV, inside0).r(), -3.0f * perlin->eval(kNoUV, inside0).r());
    EXPECT_FLOAT_EQ(product->eval(kNoUV, inside1).r(), 0.5f * perlin->eval(kNoUV, inside1).r());

    auto mix = tex(R"(<texture type="combination"><string name="operation" value="mix"/>
      <float name="weight" value="0.25"/>
      <texture type="constant"><color name="value" value="1, 0, 0"/></texture>
      <texture type="constant"><color name="value" value="0, 0, 1"/></texture>
    </texture>)");
    expectColor(mix->eval(kNoUV, kNoPoint), Color3f(0.75f, 0.0f, 0.25f));
    auto textured = tex(R"(<texture type="combination"><string name="operation" value="mix"/>
      <texture type="constant"><color name="value" value="1, 0, 0"/></texture>
      <texture type="constant"><color name="value" value="0, 0, 1"/></texture>
      <texture type="uv" name="weight"/>
    </texture>)");
    // The weight texture is per channel: (u, v, 0).
    expectColor(textured->eval(Point2f(0.5f, 0.25f), kNoPoint), Color3f(0.5f, 0.0f, 0.0f));
    expectWithinBounds(*textured);
}

TEST(Texture, ProductBoundsAreExactForASignedPair) {
    auto product = tex(R"(<texture type="combination"><string name="operation" value="product"/>
      <texture type="constant"><color name="value" value="-2"/></texture>
      <texture type="constant"><color name="value" value="3"/></texture>
    </texture>)");
    expectColor(product->eval(kNoUV, kNoPoint), Color3f(-6.0f));
    expectColor(product->lowerBound(), Color3f(-6.0f));
    expectColor(product->upperBound(), Color3f(-6.0f));
}

TEST(Texture, DiffuseAlbedoFollowsTheTexture) {
    auto bsdf = parseAs<BSDF>("diffuse_tex.xml", R"(<bsdf type="diffuse">
      <texture type="checkerboard2d" name="albedo">
        <color name="color0" value="0.8, 0.1, 0.1"/><color name="color1" value="0.1, 0.1, 0.8"/>
      </texture></bsdf>)");
    BSDFQueryRecord rec(Vector3f(0, 0, 1));
    rec.uv = Point2f(0.1f, 0.1f);
    expectColor(bsdf->sample(rec, Point2f(0.3f, 0.6f)), Color3f(0.8f, 0.1f, 0.1f));
    expectColor(bsdf->eval(rec), Color3f(0.8f, 0.1f, 0.1f) * InvPi);
    rec.uv = Point2f(0.6f, 0.1f);
    expectColor(bsdf->eval(rec), Color3f(0.1f, 0.1f, 0.8f) * InvPi);
}

// A plain albedo of -1 is refused; one from a texture was only warned about while rendering (as
// negative samples). Texture bounds are exact, so the texture is refused at its element.
TEST(Texture, DiffuseAlbedoTextureMustStayNonNegative) {
    expectParseError(
        "negative_constant_albedo.xml", R"(<bsdf type="diffuse">
  <texture type="constant" name="albedo">
    <color name="value" value="-1"/>
  </texture>
</bsdf>)",
        2,
        "(texture type=\"constant\"): the diffuse \"albedo\" must stay finite and >= 0 "
        "in every channel; this texture ranges from [-1, -1, -1] to [-1, -1, -1]");
    expectParseError("negative_checker_albedo.xml", R"(<bsdf type="diffuse">

  <texture type="checkerboard2d" name="albedo">
    <color name="color0" value="0.5"/><color name="color1" value="0.2, -0.1, 0.3"/>
  </texture>
</bsdf>)",
                     3, "the diffuse \"albedo\" must stay finite and >= 0");
    expectParseError("negative_sum_albedo.xml", R"(<bsdf type="diffuse">
  <texture type="combination" name="albedo">
    <texture type="constant"><color name="value" value="0.5"/></texture>
    <texture type="constant"><color name="value" value="-0.75"/></texture>
  </texture>
</bsdf>)",
                     2, "(texture type=\"combination\"): the diffuse \"albedo\" must stay");
    // Zero is a valid albedo (black), and so is a texture above 1, as a plain value may be.
    EXPECT_NO_THROW(parseAs<BSDF>("zero_albedo.xml", R"(<bsdf type="diffuse">
  <texture type="checkerboard2d" name="albedo">
    <color name="color0" value="0"/><color name="color1" value="1.5"/>
  </texture></bsdf>)"));
}

TEST(Texture, ClearErrors) {
    expectParseError("missing_texture.xml", R"(<scene>
  <mesh type="obj">
    <bsdf type="diffuse">
      <texture type="bitmap" name="albedo">
        <string name="filename" value="no_such_file.exr"/>
      </texture>
    </bsdf>
  </mesh>
</scene>)",
                     4, "no_such_file.exr");
    expectParseError("both_albedo.xml", R"(<bsdf type="diffuse">
  <color name="albedo" value="0.5"/>
  <texture type="constant" name="albedo"/>
</bsdf>)",
                     1, "albedo");
    expectParseError("wrong_name.xml", R"(<bsdf type="diffuse">
  <texture type="constant" name="albdo"/>
</bsdf>)",
                     1, "albdo");
    expectParseError("bad_wrap.xml", R"(<texture type="bitmap">
  <string name="filename" value="x.exr"/>
  <string name="wrapMode" value="tile"/>
</texture>)",
                     1, "wrapMode");
    expectParseError("bad_op.xml", R"(<texture type="combination">
  <string name="operation" value="divide"/>
</texture>)",
                     1, "operation");
    expectParseError("mix_three.xml", R"(<texture type="combination">
  <string name="operation" value="mix"/>
  <texture type="constant"/><texture type="constant"/><texture type="constant"/>
</texture>)",
                     1, "exactly two");
}

}  // namespace
}  // namespace alphorn
