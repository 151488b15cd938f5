#include "common/sampler/sampler.h"
#include "common/texture/plugin_testing.h"

#include <gtest/gtest.h>

#include <set>

namespace alphorn {
namespace {

using plugin_testing::expectParseError;
using plugin_testing::parseAs;

std::shared_ptr<Sampler> make(const std::string& type, int count, int dimension = 32) {
    return parseAs<Sampler>(
        "sampler.xml",
        absl::StrFormat(
            R"(<sampler type="%s">
  <integer name="sampleCount" value="%d"/>%s</sampler>)",
            type, count,
            type == "stratified"
                ? absl::StrFormat(R"(<integer name="dimension" value="%d"/>)", dimension)
                : ""));
}

// Draws the pattern of one stream: per pass, a 1D, a 2D, then a 1D draw (dimensions 0..3).
struct Draws {
    std::vector<float> a, d;
    std::vector<Point2f> bc;
};
Draws drawPasses(Sampler& s, uint64_t seed, uint64_t stream, uint32_t firstPass, uint32_t passes) {
    Draws out;
    for (uint32_t p = firstPass; p < firstPass + passes; ++p) {
        s.startStream(seed, p, stream, StreamPurpose::Camera);
        out.a.push_back(s.next1D());
        out.bc.push_back(s.next2D());
        out.d.push_back(s.next1D());
    }
    return out;
}

void expectOnePerStratum(const std::vector<float>& values, int n) {
    std::set<int> strata;
    for (float v : values) {
        ASSERT_GE(v, 0.0f);
        ASSERT_LT(v, 1.0f);
        strata.insert(int(v * n));
    }
    EXPECT_EQ(int(strata.size()), n);
}

TEST(Stratified, ExactlyOneSamplePerStratumPerDimension) {
    for (int n : {16, 10, 1, 7}) {
        auto sampler = make("stratified", n);
        for (uint64_t stream : {0ull, 12345ull})
            for (uint32_t block : {0u, 1u, 5u}) {
                const Draws d = drawPasses(*sampler, 99, stream, block * n, n);
                expectOnePerStratum(d.a, n);
                expectOnePerStratum(d.d, n);
                std::vector<float> x, y;
                std::set<std::pair<int, int>> cells;
                for (const Point2f& p : d.bc) {
                    x.push_back(p.x());
                    y.push_back(p.y());
                }
                const int side = int(std::lround(std::sqrt(n)));
                if (side * side == n) {
                    // A square count: one sample per cell of the sqrt(n) x sqrt(n) grid.
                    for (const Point2f& p : d.bc)
                        cells.insert({int(p.x() * side), int(p.y() * side)});
                    EXPECT_EQ(int(cells.size()), n);
                } else {
                    // Otherwise n strata along each axis.
                    expectOnePerStratum(x, n);
                    expectOnePerStratum(y, n);
                }
            }
    }
}

TEST(Stratified, IsAPureFunctionOfSeedPassStreamAndDimension) {
    auto sampler = make("stratified", 16);
    auto clone = sampler->clone();
    // Pass 21 alone, in another order, in a clone: the same numbers.
    const Draws all = drawPasses(*sampler, 5, 77, 16, 16);
    const Draws one = drawPasses(*clone, 5, 77, 21, 1);
    EXPECT_EQ(all.a[5], one.a[0]);
    EXPECT_EQ(all.bc[5], one.bc[0]);
    EXPECT_EQ(all.d[5], one.d[0]);
    // Other seeds, streams and blocks give other permutations.
    const Draws otherSeed = drawPasses(*sampler, 6, 77, 16, 16);
    const Draws otherStream = drawPasses(*sampler, 5, 78, 16, 16);
    const Draws otherBlock = drawPasses(*sampler, 5, 77, 32, 16);
    int same = 0;
    for (int i = 0; i < 16; ++i) {
        same += int(all.a[i] * 16) == int(otherSeed.a[i] * 16);
        same += int(all.a[i] * 16) == int(otherStream.a[i] * 16);
        same += int(all.a[i] * 16) == int(otherBlock.a[i] * 16);
    }
    EXPECT_LT(same, 16);
}

TEST(Stratified, DimensionsBeyondTheLimitAreIndependent) {
    auto sampler = make("stratified", 16, 1);
    const Draws d = drawPasses(*sampler, 3, 4, 0, 16);
    expectOnePerStratum(d.a, 16);
    // With a 2D draw past the limit, 16 uniform points rarely cover all 16 cells.
    std::set<std::pair<int, int>> cells;
    for (const Point2f& p : d.bc) cells.insert({int(p.x() * 4), int(p.y() * 4)});
    EXPECT_LT(int(cells.size()), 16);
}

// Variance of a 16-sample estimate of a smooth integral over many pixels. Jittered sampling in
// d dimensions has variance O(n^(-1-2/d)) against O(n^-1): for n = 16 about 1/16 (2D) and 1/256
// (1D) of independent sampling up to constants; the bounds leave room for those constants.
TEST(Stratified, LowerVarianceThanIndependentOnASmoothIntegrand) {
    auto f = [](const Point2f& p) {
        return std::exp(p.x()) * std::sin(Pi * p.y()) + p.x() * p.y();
    };
    const double exact = (std::exp(1.0) - 1.0) * 2.0 / M_PI + 0.25;
    auto g = [](float x) { return std::exp(x) + x * x; };
    auto variance = [&](Sampler& s, bool oneD) {
        double sum = 0, sum2 = 0;
        const int streams = 400, n = 16;
        for (int stream = 0; stream < streams; ++stream) {
            double estimate = 0;
            for (int p = 0; p < n; ++p) {
                s.startStream(1, p, stream, StreamPurpose::Camera);
                s.next2D();  // the pixel position, as the renderer draws it
                estimate += (oneD ? g(s.next1D()) : f(s.next2D())) / n;
            }
            sum += estimate;
            sum2 += estimate * estimate;
        }
        const double mean = sum / streams;
        EXPECT_NEAR(mean, oneD ? std::exp(1.0) - 1.0 + 1.0 / 3.0 : exact, 0.02);
        return sum2 / streams - mean * mean;
    };
    const double stratified = variance(*make("stratified", 16), false);
    const double independent = variance(*make("independent", 16), false);
    EXPECT_LT(stratified, 0.3 * independent) << stratified << " vs " << independent;
    const double stratified1D = variance(*make("stratified", 16), true);
    const double independent1D = variance(*make("independent", 16), true);
    EXPECT_LT(stratified1D, 0.02 * independent1D) << stratified1D << " vs " << independent1D;
}

TEST(Stratified, ClearErrors) {
    expectParseError("stratified_bad.xml", R"(<sampler type="stratified">
  <integer name="sampleCount" value="0"/>
</sampler>)",
                     1, "sampleCount");
    expectParseError("stratified_dim.xml", R"(<sampler type="stratified">
  <integer name="dimension" value="-1"/>
</sampler>)",
                     1, "dimension");
}

}  // namespace
}  // namespace alphorn
