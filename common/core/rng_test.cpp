#include "common/core/rng.h"

#include <gtest/gtest.h>

#include <cmath>

namespace alphorn {
namespace {

TEST(Rng, StreamsArePureFunctionsOfTheirKey) {
    Rng a(7, 3, 1000, StreamPurpose::Camera), b(7, 3, 1000, StreamPurpose::Camera);
    for (int i = 0; i < 100; ++i) EXPECT_EQ(a.nextUInt(), b.nextUInt());
}

TEST(Rng, DifferentKeysGiveDifferentStreams) {
    auto first = [](uint64_t seed, uint64_t pass, uint64_t stream, StreamPurpose p) {
        Rng r(seed, pass, stream, p);
        return r.nextUInt();
    };
    uint32_t base = first(7, 3, 1000, StreamPurpose::Camera);
    EXPECT_NE(base, first(8, 3, 1000, StreamPurpose::Camera));
    EXPECT_NE(base, first(7, 4, 1000, StreamPurpose::Camera));
    EXPECT_NE(base, first(7, 3, 1001, StreamPurpose::Camera));
    EXPECT_NE(base, first(7, 3, 1000, StreamPurpose::Photon));
}

TEST(Rng, FloatsAreInTheHalfOpenUnitInterval) {
    Rng r(1, 2, 3, StreamPurpose::Test);
    double sum = 0.0;
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
        float u = r.nextFloat();
        ASSERT_GE(u, 0.0f);
        ASSERT_LT(u, 1.0f);
        double d = r.nextDouble();
        ASSERT_GE(d, 0.0);
        ASSERT_LT(d, 1.0);
        sum += u;
    }
    // Mean of U(0,1) is 1/2 with standard error 1/sqrt(12 n) ~ 0.0009; allow 5 sigma.
    EXPECT_NEAR(sum / n, 0.5, 5.0 / std::sqrt(12.0 * n));
}

}  // namespace
}  // namespace alphorn
