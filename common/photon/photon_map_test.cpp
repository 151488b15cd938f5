// Photon map indexes and density estimates against brute force and closed forms.
#include "common/photon/photon_map.h"
#include "common/photon/density_estimate.h"

#include "common/core/rng.h"
#include "common/stats/student_t.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace alphorn {
namespace {

Photons randomPhotons(size_t count, uint64_t seed, float extent = 1.0f) {
    Photons photons(count);
    for (size_t i = 0; i < count; ++i) {
        Rng rng(seed, 0, i, StreamPurpose::Test);
        const float x = rng.nextFloat(), y = rng.nextFloat(), z = rng.nextFloat();
        photons[i].position = Point3f(x, y, z) * extent;
        photons[i].direction = Vector3f(0.0f, 0.0f, 1.0f);
        photons[i].power = Color3f(1.0f + float(i % 7), 1.0f, 0.5f);
    }
    return photons;
}

// Squared distance with the indexes' arithmetic (term by term, in float).
float distance2(const Point3f& a, const Point3f& b) {
    float d2 = 0.0f;
    for (int i = 0; i < 3; ++i) d2 += (a[i] - b[i]) * (a[i] - b[i]);
    return d2;
}

std::vector<uint32_t> bruteForceWithin(const Photons& photons, const Point3f& x, float radius) {
    std::vector<uint32_t> found;
    for (uint32_t i = 0; i < photons.size(); ++i)
        if (distance2(photons[i].position, x) < radius * radius) found.push_back(i);
    return found;
}

TEST(PhotonMap, GridAndKdTreeFindExactlyThePhotonsWithinTheRadius) {
    const Photons photons = randomPhotons(20000, 1);
    PhotonKdTree tree(photons.data(), photons.size());
    for (float radius : {0.003f, 0.02f, 0.1f}) {
        PhotonHashGrid grid(photons.data(), photons.size(), radius);
        size_t total = 0;
        for (uint64_t q = 0; q < 300; ++q) {
            Rng rng(2, 0, q, StreamPurpose::Test);
            // Queries inside, on the edge of and outside the cloud, and every other one at a
            // photon (so that the small radii find something).
            Point3f x(rng.nextFloat() * 1.2f - 0.1f, rng.nextFloat() * 1.2f - 0.1f,
                      rng.nextFloat() * 1.2f - 0.1f);
            if (q % 2 == 0) x = photons[(q * 7919) % photons.size()].position;
            // Also a smaller query radius than the grid was built for.
            for (float r : {radius, 0.5f * radius}) {
                std::vector<uint32_t> expected = bruteForceWithin(photons, x, r), fromGrid,
                                      fromTree;
                grid.forEachWithin(x, r, [&](uint32_t i, float d2) {
                    fromGrid.push_back(i);
                    EXPECT_EQ(d2, distance2(photons[i].position, x));
                });
                tree.forEachWithin(x, r, [&](uint32_t i, float) { fromTree.push_back(i); });
                std::sort(fromGrid.begin(), fromGrid.end());
                std::sort(fromTree.begin(), fromTree.end());
                EXPECT_EQ(fromGrid, expected) << "grid, radius " << r;
                EXPECT_EQ(fromTree, expected) << "k-d tree, radius " << r;
                total += expected.size();
            }
        }
        EXPECT_GT(total, 0u) << "vacuous test at radius " << radius;
    }
}

TEST(PhotonMap, GridVisitsItsPhotonCopiesInTheOrderOfItsIndices) {
    // Gathers read the grid's own copies of the photons (locality); they must be the photons of
    // the array, visited in exactly the order forEachWithin() gives their indices, or a density
    // estimate's sum would change.
    Photons photons = randomPhotons(5000, 4);
    for (size_t i = 0; i < photons.size(); ++i)
        photons[i].direction = Vector3f(float(i), 1.0f, 0.0f).normalized();
    const float radius = 0.1f;
    PhotonHashGrid grid(photons.data(), photons.size(), radius);
    size_t total = 0;
    for (uint64_t q = 0; q < 100; ++q) {
        const Point3f x = photons[(q * 7919) % photons.size()].position;
        std::vector<uint32_t> indices;
        std::vector<float> byIndex, byCopy;
        grid.forEachWithin(x, radius, [&](uint32_t i, float d2) {
            indices.push_back(i);
            byIndex.push_back(d2);
        });
        size_t n = 0;
        grid.forEachPhotonWithin(x, radius, [&](const Photon& photon, float d2) {
            ASSERT_LT(n, indices.size());
            const Photon& original = photons[indices[n]];
            EXPECT_EQ(photon.position, original.position);
            EXPECT_EQ(photon.direction, original.direction);
            EXPECT_TRUE((photon.power == original.power).all());
            byCopy.push_back(d2);
            ++n;
        });
        EXPECT_EQ(n, indices.size());
        EXPECT_EQ(byIndex, byCopy);
        total += n;
    }
    EXPECT_GT(total, 500u);
}

TEST(PhotonMap, GridHandlesPhotonsOnCellFacesAndDuplicates) {
    // Photons on a lattice whose spacing equals the grid's cell size, and exact duplicates:
    // points on cell faces must be found from both sides, and duplicates all counted.
    Photons photons;
    const float radius = 0.05f, cell = 2.0f * radius * 1.0001f;
    for (int i = -3; i <= 3; ++i)
        for (int j = -3; j <= 3; ++j)
            for (int copy = 0; copy < 2; ++copy)
                photons.push_back(
                    Photon{Point3f(i * cell, j * cell, 0.0f), Vector3f::UnitZ(), Color3f(1.0f)});
    PhotonHashGrid grid(photons.data(), photons.size(), radius);
    for (const Photon& target : photons) {
        for (const Vector3f& offset : {Vector3f(0.0f, 0.0f, 0.0f), Vector3f(0.049f, 0.0f, 0.0f),
                                       Vector3f(-0.03f, 0.03f, 0.01f)}) {
            const Point3f x = target.position + offset;
            size_t fromGrid = 0;
            grid.forEachWithin(x, radius, [&](uint32_t, float) { ++fromGrid; });
            EXPECT_EQ(fromGrid, bruteForceWithin(photons, x, radius).size());
        }
    }
}

TEST(PhotonMap, GridScansCrowdedCellsAcrossItsBatchesInIndexOrder) {
    // The scan works through a bucket in batches of entries; a cell holding several batches'
    // worth, some inside the query sphere and some not, must yield exactly the photons inside,
    // in photon-index order, whatever the batch boundaries. The photons fill a cube smaller
    // than a cell (side 2.0002 r) from the grid's origin: one cell, one bucket.
    const float radius = 0.1f;
    Photons photons = randomPhotons(1000, 5, 0.19f);
    for (Photon& photon : photons) photon.position += Vector3f(0.5f, 0.5f, 0.5f);
    PhotonHashGrid grid(photons.data(), photons.size(), radius);
    size_t total = 0;
    for (float r : {0.01f, 0.05f, radius}) {
        for (uint64_t q = 0; q < 50; ++q) {
            const Point3f x = photons[(q * 7919) % photons.size()].position;
            std::vector<uint32_t> fromGrid;
            grid.forEachWithin(x, r, [&](uint32_t i, float) { fromGrid.push_back(i); });
            EXPECT_EQ(fromGrid, bruteForceWithin(photons, x, r)) << "radius " << r;
            total += fromGrid.size();
        }
    }
    EXPECT_GT(total, 5000u);
}

TEST(PhotonMap, NearestNeighboursMatchBruteForceAndRespectTheSearchRadius) {
    const Photons photons = randomPhotons(5000, 3);
    PhotonMap map(photons, PhotonMap::Lookup::Nearest);
    std::vector<PhotonNeighbor> out(64);
    for (uint64_t q = 0; q < 200; ++q) {
        Rng rng(4, 0, q, StreamPurpose::Test);
        const Point3f x(rng.nextFloat(), rng.nextFloat(), rng.nextFloat());
        std::vector<float> all;
        for (const Photon& p : photons) all.push_back(distance2(p.position, x));
        std::sort(all.begin(), all.end());
        for (size_t k : {size_t(2), size_t(10), size_t(64)}) {
            for (float maxRadius : {10.0f, 0.05f}) {
                const size_t found = map.nearest(x, k, maxRadius, out.data());
                const size_t inside = static_cast<size_t>(
                    std::lower_bound(all.begin(), all.end(), maxRadius * maxRadius) - all.begin());
                ASSERT_EQ(found, std::min(k, inside)) << "k " << k << " max " << maxRadius;
                for (size_t i = 0; i < found; ++i) {
                    EXPECT_EQ(out[i].distance2, all[i]) << i;
                    EXPECT_EQ(out[i].distance2, distance2(photons[out[i].index].position, x));
                }
            }
        }
    }
}

TEST(PhotonMap, EmptyMapsAnswerNothingAndEstimateZero) {
    const auto weight = [](const Photon& p) { return p.power; };
    for (auto lookup : {PhotonMap::Lookup::Radius, PhotonMap::Lookup::Nearest}) {
        PhotonMap map({}, lookup, 0.1f);
        EXPECT_TRUE(map.empty());
        size_t visited = 0;
        map.forEachWithin(Point3f::Zero(), 0.1f, [&](const Photon&, float) { ++visited; });
        EXPECT_EQ(visited, 0u);
        const Color3f fixed = fixedRadiusEstimate(map, Point3f::Zero(), 0.1f, weight);
        EXPECT_TRUE(fixed.isBlack());
        if (lookup == PhotonMap::Lookup::Nearest) {
            const Color3f knn = nearestNeighbourEstimate(map, Point3f::Zero(), 10, 0.1f, weight);
            EXPECT_TRUE(knn.isBlack()) << knn;
            EXPECT_TRUE(knn.allFinite());
        }
    }
}

TEST(PhotonMap, EstimatesUseTheirDocumentedNormalisation) {
    // Photons at known distances from the origin, with powers 1, 2, 3, ...
    Photons photons;
    for (int i = 0; i < 6; ++i)
        photons.push_back(Photon{Point3f(0.1f * float(i + 1), 0.0f, 0.0f), Vector3f::UnitZ(),
                                 Color3f(float(i + 1))});
    const auto weight = [](const Photon& p) { return p.power; };
    const Point3f origin = Point3f::Zero();
    const double pi = 3.14159265358979323846;
    {
        // Fixed radius 0.35: photons at 0.1, 0.2, 0.3 count: (1 + 2 + 3) / (pi 0.35²).
        PhotonMap map(photons, PhotonMap::Lookup::Radius, 0.35f);
        EXPECT_NEAR(fixedRadiusEstimate(map, origin, 0.35f, weight).r(), 6.0 / (pi * 0.35f * 0.35f),
                    1e-4);
    }
    PhotonMap map(photons, PhotonMap::Lookup::Nearest);
    // k = 4: the three nearer photons over the disk through the fourth: (1 + 2 + 3) / (pi 0.4²).
    const double r4 = double(0.4f) * double(0.4f);
    EXPECT_NEAR(nearestNeighbourEstimate(map, origin, 4, 10.0f, weight).r(), 6.0 / (pi * r4), 1e-3);
    // Fewer than k within the search radius 0.45 (four photons, k = 5): all of them over the
    // search disk, (1 + 2 + 3 + 4) / (pi 0.45²), not over the disk through the last one found.
    EXPECT_NEAR(nearestNeighbourEstimate(map, origin, 5, 0.45f, weight).r(),
                10.0 / (pi * double(0.45f) * double(0.45f)), 1e-3);
    // k larger than the whole map: the same rule; finite, never inflated.
    const Color3f all = nearestNeighbourEstimate(map, origin, 50, 1.0f, weight);
    EXPECT_NEAR(all.r(), 21.0 / pi, 1e-3);
    // k photons all exactly at the query point: r_k = 0 must not divide by zero.
    Photons stacked(3, Photon{origin, Vector3f::UnitZ(), Color3f(1.0f)});
    PhotonMap stackedMap(stacked, PhotonMap::Lookup::Nearest);
    const Color3f s = nearestNeighbourEstimate(stackedMap, origin, 3, 0.5f, weight);
    EXPECT_TRUE(s.allFinite());
    EXPECT_NEAR(s.r(), 3.0 / (pi * 0.25), 1e-3);
}

// (k − 1)/(π r_k²) is unbiased for uniformly spread photons; k/(π r_k²) is k/(k − 1) too high.
// Many independent maps of n photons uniform on the unit square (z = 0); the kNN estimate at
// the centre must average to the density n, by a Student t-test at 1%. The same samples scaled
// by k/(k − 1) (the common normalisation) must fail it.
TEST(PhotonMap, NearestNeighbourEstimateIsUnbiasedForUniformPhotons) {
    constexpr int kMaps = 3000, kPhotons = 400;
    constexpr size_t k = 4;
    stats::RunningStats ours, common;
    for (int m = 0; m < kMaps; ++m) {
        Photons photons(kPhotons);
        for (int i = 0; i < kPhotons; ++i) {
            Rng rng(5, m, i, StreamPurpose::Test);
            const float x = rng.nextFloat(), y = rng.nextFloat();
            photons[i] = Photon{Point3f(x, y, 0.0f), Vector3f::UnitZ(), Color3f(1.0f)};
        }
        PhotonMap map(std::move(photons), PhotonMap::Lookup::Nearest);
        const double e =
            nearestNeighbourEstimate(map, Point3f(0.5f, 0.5f, 0.0f), k, 1.0f, [](const Photon& p) {
                return p.power;
            }).r();
        ours.add(e);
        common.add(e * double(k) / double(k - 1));
    }
    const auto good = stats::studentTTest(ours.mean, ours.variance(), kPhotons, ours.count, 0.01);
    EXPECT_TRUE(good.passed) << good.message;
    const auto bad =
        stats::studentTTest(common.mean, common.variance(), kPhotons, common.count, 0.01);
    EXPECT_FALSE(bad.passed) << "the test cannot tell k from k - 1: " << bad.message;
}

}  // namespace
}  // namespace alphorn
