#include "common/filter/rfilter.h"

#include <gtest/gtest.h>

#include <cmath>

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

}  // namespace
}  // namespace alphorn
