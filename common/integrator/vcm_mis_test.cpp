// The MIS weights of bdpt and vcm (vcm_mis.h): for random paths of 2 to 6 vertices, random
// densities and random delta surfaces, the weights of all strategies that can produce the path
// sum to one, for every combination of enabled strategies the integrators use; a strategy that
// cannot produce the path (a connection at a delta surface, a hit of a point light, a disabled
// family) has weight zero.
#include "common/integrator/vcm_mis.h"
#include "common/core/rng.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace alphorn {
namespace {

struct Family {
    const char* name;
    MisStrategies strategies;
};

std::vector<Family> families() {
    MisStrategies bdpt;
    bdpt.lightPathCount = 300.0;
    MisStrategies vcm = bdpt;
    vcm.merging = true;
    vcm.mergeArea = 0.002;
    MisStrategies mergingOnly = vcm;
    mergingOnly.connections = mergingOnly.lightTracing = false;
    MisStrategies lightTracingOnly = bdpt;
    lightTracingOnly.hits = lightTracingOnly.connections = false;
    return {{"bdpt", bdpt},
            {"vcm", vcm},
            {"merging only", mergingOnly},
            {"light tracing only", lightTracingOnly}};
}

// Log-uniform densities over eight decades, the range a scene's area densities span.
double randomDensity(Rng& rng) {
    return std::pow(10.0, 8.0 * rng.nextFloat() - 4.0);
}

TEST(VcmMis, WeightsOfEveryPathSumToOne) {
    Rng rng(11, 0, 0, StreamPurpose::Test);
    int pathsWithTwoOrMoreStrategies = 0;
    for (const Family& family : families()) {
        for (size_t vertices = 2; vertices <= 6; ++vertices) {
            for (int trial = 0; trial < 2000; ++trial) {
                std::vector<MisVertex> path(vertices);
                for (size_t i = 0; i < vertices; ++i) {
                    path[i].pdfFromLight = randomDensity(rng);
                    path[i].pdfFromCamera = randomDensity(rng);
                    // Inner vertices may be delta surfaces; the emitter and the camera never.
                    path[i].connectible = i == 0 || i + 1 == vertices || rng.nextFloat() < 0.7f;
                }
                MisStrategies strategies = family.strategies;
                strategies.emitterHittable = rng.nextFloat() < 0.6f;
                double sum = 0.0;
                int used = 0;
                for (size_t s = 0; s < vertices; ++s) {
                    const double w = misWeight(path.data(), vertices, strategies,
                                               {MisStrategy::Kind::Connection, int(s)});
                    EXPECT_GE(w, 0.0);
                    sum += w;
                    used += w > 0.0;
                }
                for (size_t m = 0; m < vertices; ++m) {
                    const double w = misWeight(path.data(), vertices, strategies,
                                               {MisStrategy::Kind::Merge, int(m)});
                    EXPECT_GE(w, 0.0);
                    sum += w;
                    used += w > 0.0;
                }
                if (used == 0) continue;  // e.g. light tracing only with a delta last vertex
                pathsWithTwoOrMoreStrategies += used >= 2;
                ASSERT_NEAR(sum, 1.0, 1e-9)
                    << family.name << ", " << vertices << " vertices, trial " << trial;
            }
        }
    }
    EXPECT_GT(pathsWithTwoOrMoreStrategies, 10000) << "a vacuous test";
}

TEST(VcmMis, ImpossibleStrategiesWeighNothing) {
    // x_0 light, x_1 mirror, x_2 diffuse, x_3 camera.
    std::vector<MisVertex> path = {
        {0.5, 2.0, true}, {1.0, 1.0, false}, {3.0, 0.7, true}, {1.0, 1.0, true}};
    MisStrategies vcm;
    vcm.merging = true;
    vcm.mergeArea = 0.01;
    vcm.lightPathCount = 100.0;
    vcm.emitterHittable = false;  // a point light
    auto weight = [&](MisStrategy::Kind kind, int index) {
        return misWeight(path.data(), path.size(), vcm, {kind, index});
    };
    EXPECT_EQ(weight(MisStrategy::Kind::Connection, 0), 0.0);  // hitting a point light
    EXPECT_EQ(weight(MisStrategy::Kind::Connection, 1), 0.0);  // connecting to the mirror
    EXPECT_EQ(weight(MisStrategy::Kind::Connection, 2), 0.0);  // connecting from the mirror
    EXPECT_EQ(weight(MisStrategy::Kind::Merge, 1), 0.0);       // merging on the mirror
    // Light tracing from x_2 and merging at x_2 are what remains (a caustic seen directly).
    EXPECT_GT(weight(MisStrategy::Kind::Connection, 3), 0.0);
    EXPECT_GT(weight(MisStrategy::Kind::Merge, 2), 0.0);
    EXPECT_NEAR(weight(MisStrategy::Kind::Connection, 3) + weight(MisStrategy::Kind::Merge, 2), 1.0,
                1e-12);
    // The balance heuristic: light tracing's density is N p_L(x_0) p_L(x_1) p_L(x_2), merging's
    // N pi r^2 p_L(x_0) p_L(x_1) p_L(x_2) p_C(x_2).
    EXPECT_NEAR(weight(MisStrategy::Kind::Connection, 3), 1.0 / (1.0 + 0.01 * 0.7), 1e-12);
}

TEST(VcmMis, AnEmitterSeenDirectlyIsLeftToTheCameraPath) {
    // x_0 on an area light, x_1 the camera: the camera path's hit takes the whole weight, light
    // tracing the emitter point to the camera none, whatever the densities; light tracing keeps
    // it only when hits are off (light tracing alone) or the light cannot be hit.
    const std::vector<MisVertex> path = {{0.02, 50.0, true}, {1.0, 1.0, true}};
    MisStrategies bdpt;
    bdpt.lightPathCount = 1e6;
    auto weight = [&](const MisStrategies& strategies, int s) {
        return misWeight(path.data(), path.size(), strategies, {MisStrategy::Kind::Connection, s});
    };
    EXPECT_EQ(weight(bdpt, 0), 1.0);
    EXPECT_EQ(weight(bdpt, 1), 0.0);
    MisStrategies lightTracingOnly = bdpt;
    lightTracingOnly.hits = false;
    EXPECT_EQ(weight(lightTracingOnly, 1), 1.0);
    // One bounce further, light tracing is one strategy among the others again.
    const std::vector<MisVertex> bounce = {{0.02, 50.0, true}, {0.3, 0.4, true}, {1.0, 1.0, true}};
    EXPECT_GT(misWeight(bounce.data(), bounce.size(), bdpt, {MisStrategy::Kind::Connection, 2}),
              0.0);
}

}  // namespace
}  // namespace alphorn
