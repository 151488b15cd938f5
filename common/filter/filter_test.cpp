#include "common/filter/rfilter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace alphorn {
namespace {

std::shared_ptr<ReconstructionFilter> makeGaussian(float radius, float stddev) {
    PropertyList props("test");
    props.setFloat("radius", radius);
    props.setFloat("stddev", stddev);
    auto filter = std::static_pointer_cast<ReconstructionFilter>(
        ObjectFactory::create(ObjectKind::Filter, "gaussian", props));
    filter->activate();
    return filter;
}

// The gaussian reaches zero at its radius by subtracting its value there. The weights are part of
// every image's bytes, so they must be exactly the floats of the defining formula, whatever is
// computed ahead.
TEST(GaussianFilter, WeightsAreExactlyTheShiftedGaussian) {
    for (float radius : {2.0f, 0.7f, 3.3f}) {
        for (float stddev : {0.5f, 0.31f, 1.2f}) {
            const auto filter = makeGaussian(radius, stddev);
            const float alpha = -1.0f / (2.0f * stddev * stddev);
            for (int i = 0; i <= 40; ++i) {
                const float x = radius * (static_cast<float>(i) / 37.0f - 0.03f);
                const float expected =
                    std::max(0.0f, std::exp(alpha * x * x) - std::exp(alpha * radius * radius));
                EXPECT_EQ(filter->eval(x), expected) << radius << " " << stddev << " " << x;
                EXPECT_EQ(filter->eval(-x), expected);
            }
            EXPECT_EQ(filter->eval(radius), 0.0f);
        }
    }
}

// The film weighs taps by the filter's table: eval at the centre of the bin of width radius / 256
// that holds |x|, the same on both sides, the last bin's value up to the radius itself, and
// within the filter's variation over one bin of eval(x) (a table off by one bin, or sampled at
// the bins' edges, fails).
TEST(Filters, TapsAreWeighedByTheTabulatedFilter) {
    for (const std::string type : {"gaussian", "mitchell", "box", "tent"}) {
        PropertyList props("test");
        if (type == "mitchell") props.setFloat("radius", 2.5f);
        const auto filter = std::static_pointer_cast<ReconstructionFilter>(
            ObjectFactory::create(ObjectKind::Filter, type, props));
        const float radius = filter->radius();
        const float bin = radius / static_cast<float>(ReconstructionFilter::kTableSize);
        for (int i = 0; i < ReconstructionFilter::kTableSize; ++i) {
            const float centre = (static_cast<float>(i) + 0.5f) * bin;
            const float expected = filter->eval(centre);
            for (const float x : {centre, (static_cast<float>(i) + 0.05f) * bin,
                                  (static_cast<float>(i) + 0.95f) * bin}) {
                ASSERT_EQ(filter->weight(x), expected) << type << " bin " << i << " x " << x;
                ASSERT_EQ(filter->weight(-x), expected) << type << " bin " << i << " x " << -x;
            }
        }
        EXPECT_EQ(filter->weight(radius), filter->eval(radius - 0.5f * bin)) << type;
        // Within the filter's change across one bin of the exact value (the box has none).
        if (type == "box") continue;
        for (int i = 0; i <= 1000; ++i) {
            const float x = radius * static_cast<float>(i) / 1000.0f;
            const float slope = std::max(std::abs(filter->eval(x + bin) - filter->eval(x)),
                                         std::abs(filter->eval(x) - filter->eval(x - bin)));
            EXPECT_LE(std::abs(filter->weight(x) - filter->eval(x)), slope) << type << " " << x;
        }
    }
}

// Creating the filter of `type` with the float parameters given must fail, naming where it was
// written and every fragment.
void expectRefused(const std::string& type,
                   std::initializer_list<std::pair<const char*, float>> floats,
                   std::initializer_list<std::string> fragments) {
    PropertyList props("scene.xml:7:5 (rfilter type=\"" + type + "\")");
    for (const auto& [name, value] : floats) props.setFloat(name, value);
    try {
        ObjectFactory::create(ObjectKind::Filter, type, props);
        ADD_FAILURE() << type << " accepted parameters that should be refused";
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("scene.xml:7:5 (rfilter type=\"" + type + "\")"), std::string::npos)
            << message;
        for (const std::string& fragment : fragments)
            EXPECT_NE(message.find(fragment), std::string::npos)
                << "\"" << message << "\" lacks \"" << fragment << "\"";
    }
}

// B or C of NaN made every Mitchell weight NaN (an all-1 image), 1e30 made a black one.
TEST(MitchellFilter, RefusesBAndCOutsideZeroToOne) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    expectRefused("mitchell", {{"B", nan}}, {"\"B\" must be in [0, 1], got nan"});
    expectRefused("mitchell", {{"C", inf}}, {"\"C\" must be in [0, 1], got inf"});
    expectRefused("mitchell", {{"B", 1e30f}}, {"\"B\" must be in [0, 1], got 1e+30"});
    expectRefused("mitchell", {{"C", -0.25f}}, {"\"C\" must be in [0, 1], got -0.25"});
    expectRefused("mitchell", {{"B", 1.5f}}, {"\"B\" must be in [0, 1], got 1.5"});
    PropertyList catmullRom("test");
    catmullRom.setFloat("B", 0.0f);
    catmullRom.setFloat("C", 0.5f);
    EXPECT_NO_THROW(ObjectFactory::create(ObjectKind::Filter, "mitchell", catmullRom));
}

// A radius or a gaussian's stddev of 1e-30 reached no pixel centre from almost any sample (a black
// image); a stddev of 1e30 made every gaussian weight 0.
TEST(Filters, RefuseRadiiAndWidthsThatLoseTheSamples) {
    for (const std::string type : {"box", "gaussian", "mitchell"}) {
        expectRefused(type, {{"radius", 1e-30f}},
                      {"filter radius 1e-30 is too small (at least 0.5 pixels"});
        expectRefused(type, {{"radius", 0.49f}}, {"filter radius 0.49 is too small"});
        PropertyList halfPixel("test");
        halfPixel.setFloat("radius", 0.5f);
        if (type == "gaussian") halfPixel.setFloat("stddev", 0.5f);
        EXPECT_NO_THROW(ObjectFactory::create(ObjectKind::Filter, type, halfPixel)) << type;
    }
    expectRefused("gaussian", {{"stddev", 1e-30f}},
                  {"\"stddev\" 1e-30 is too small (at least 0.1 pixels)"});
    expectRefused("gaussian", {{"stddev", 0.09f}}, {"\"stddev\" 0.09 is too small"});
    expectRefused("gaussian", {{"stddev", 1e30f}},
                  {"\"stddev\" 1e+30 is too large (at most 10 times the radius 2)"});
    expectRefused("gaussian", {{"radius", 0.5f}, {"stddev", 5.01f}},
                  {"\"stddev\" 5.01 is too large (at most 10 times the radius 0.5)"});
    EXPECT_NO_THROW(makeGaussian(0.5f, 0.1f));
    EXPECT_NO_THROW(makeGaussian(0.5f, 5.0f));
}

}  // namespace
}  // namespace alphorn
