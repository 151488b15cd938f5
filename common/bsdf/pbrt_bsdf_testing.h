// Helpers shared by the unit tests of the pbrt-v4 style BSDFs: building a BSDF from properties,
// directions at given angles, and a chi-square test of a BSDF's non-delta sampling against its
// pdf() over the whole sphere (the histogram machinery of common/stats).
#pragma once

#include "common/bsdf/bsdf.h"
#include "common/core/rng.h"
#include "common/stats/chi_square.h"
#include "common/stats/spherical_histogram.h"

#include <gtest/gtest.h>

namespace alphorn::testing {

inline std::shared_ptr<BSDF> makeBSDF(const std::string& type,
                                      const PropertyList& props = PropertyList()) {
    auto bsdf =
        std::static_pointer_cast<BSDF>(ObjectFactory::create(ObjectKind::BSDF, type, props));
    bsdf->activate();
    return bsdf;
}

inline Vector3f directionAt(float thetaDeg, float phi = 0.3f) {
    return sphericalDirection(degToRad(thetaDeg), phi);
}

// Samples of weight 0 and delta samples (Measure::Discrete) are not part of the density pdf()
// describes, so they are left out; the pdf must integrate to the chance of the rest.
inline stats::Chi2Result bsdfChi2(const BSDF& bsdf, const Vector3f& wi, int sampleCount,
                                  uint64_t stream, double alpha) {
    stats::SphericalGrid grid;
    std::vector<double> observed(grid.cellCount(), 0.0);
    Rng rng(0x5eed, stream, 0, StreamPurpose::Test);
    for (int i = 0; i < sampleCount; ++i) {
        BSDFQueryRecord rec(wi);
        const float u = rng.nextFloat();
        const Color3f w = bsdf.sample(rec, Point2f(u, rng.nextFloat()));
        if (w.isBlack() || rec.measure == Measure::Discrete) continue;
        EXPECT_TRUE(w.allFinite());
        observed[grid.cellOf(rec.wo)] += 1.0;
    }
    const std::vector<double> expected = stats::expectedFrequencies(
        grid,
        [&](const Vector3f& wo) {
            return double(bsdf.pdf(BSDFQueryRecord(wi, wo, Measure::SolidAngle)));
        },
        sampleCount);
    return stats::chi2Test(observed, expected, sampleCount, 5.0, alpha);
}

}  // namespace alphorn::testing
