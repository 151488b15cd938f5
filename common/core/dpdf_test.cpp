#include "common/core/dpdf.h"
#include "common/core/rng.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace alphorn {
namespace {

// Short tables are sampled by counting their bounds; the index (and the reused number) must be
// the binary search's for every u, at the bounds themselves, around them, beyond [0, 1), NaN,
// and with zero weights that the search skips.
TEST(DiscretePDF, ShortTablesGiveTheSearchsIndex) {
    const std::vector<std::vector<double>> tables = {
        {1.0},
        {1.0, 1.0},
        {0.25, 0.75},
        {0.0, 1.0},
        {1.0, 0.0},
        {0.0, 0.0, 3.0, 0.0, 1.0},
        {1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0},
        {0.1, 0.2, 0.0, 0.0, 0.3, 0.1, 0.0, 0.3},
        {1e-30, 1.0, 1e-30},
        {1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0},  // too long: searched either way
    };
    Rng rng(11, 0, 0, StreamPurpose::Test);
    int counted = 0;
    for (const auto& weights : tables) {
        DiscretePDF pdf;
        for (double w : weights) pdf.append(w);
        pdf.normalize();
        std::vector<float> us = {0.0f,
                                 -0.0f,
                                 -1.0f,
                                 1.0f,
                                 0.99999994f,
                                 2.0f,
                                 std::numeric_limits<float>::quiet_NaN(),
                                 std::numeric_limits<float>::infinity()};
        // Each inner bound, as float and one ulp either side.
        double bound = 0.0;
        for (size_t i = 0; i < pdf.size(); ++i) {
            bound += pdf[i];
            const float b = static_cast<float>(bound);
            us.insert(us.end(), {b, std::nextafter(b, 0.0f), std::nextafter(b, 2.0f)});
        }
        for (int i = 0; i < 2000; ++i) us.push_back(rng.nextFloat());
        for (float u : us) {
            SCOPED_TRACE(testing::Message() << weights.size() << " weights, u " << u);
            const size_t expected = pdf.sampleBySearch(u);
            ASSERT_EQ(pdf.sample(u), expected);
            float reused = u;
            ASSERT_EQ(pdf.sampleReuse(reused), expected);
            ++counted;
        }
    }
    EXPECT_GT(counted, 20000);
}

}  // namespace
}  // namespace alphorn
