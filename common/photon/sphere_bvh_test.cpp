// The beam radiance estimate's query: both indexes (our BVH and Embree's) must return exactly the
// spheres that brute force finds -- same indices, same order (by t, then index), same t -- for
// fixed and per-sphere radii, with the segment clipped at both ends.
#include "common/photon/sphere_bvh.h"

#include "common/core/rng.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <memory>

namespace alphorn {
namespace {

struct Spheres {
    std::vector<Point3f> centres;
    std::vector<float> radii;
};

Spheres randomSpheres(size_t count, bool perSphereRadius, uint64_t seed) {
    Rng rng(seed, 0, 0, StreamPurpose::Test);
    Spheres s;
    for (size_t i = 0; i < count; ++i) {
        s.centres.emplace_back(2.0f * rng.nextFloat() - 1.0f, 2.0f * rng.nextFloat() - 1.0f,
                               2.0f * rng.nextFloat() - 1.0f);
        if (perSphereRadius) s.radii.push_back(0.01f + 0.15f * rng.nextFloat());
    }
    if (!perSphereRadius) s.radii.push_back(0.08f);
    return s;
}

void expectSameHits(const std::vector<SphereHit>& expected, const std::vector<SphereHit>& actual,
                    const char* what, int query) {
    ASSERT_EQ(expected.size(), actual.size()) << what << ", query " << query;
    for (size_t i = 0; i < expected.size(); ++i) {
        EXPECT_EQ(expected[i].index, actual[i].index) << what << ", query " << query;
        EXPECT_EQ(expected[i].t, actual[i].t) << what << ", query " << query;
    }
}

void checkAgainstBruteForce(bool perSphereRadius) {
    const Spheres s = randomSpheres(5000, perSphereRadius, perSphereRadius ? 2 : 1);
    const SphereBvh bvh(s.centres, s.radii);
    const EmbreeSphereIndex embree(s.centres, s.radii);
    Rng rng(7, 0, 0, StreamPurpose::Test);
    size_t total = 0;
    for (int q = 0; q < 400; ++q) {
        const Point3f origin(3.0f * rng.nextFloat() - 1.5f, 3.0f * rng.nextFloat() - 1.5f,
                             3.0f * rng.nextFloat() - 1.5f);
        Vector3f direction(rng.nextFloat() - 0.5f, rng.nextFloat() - 0.5f, rng.nextFloat() - 0.5f);
        if (q % 10 == 0) direction = Vector3f(0.0f, 0.0f, 1.0f);  // axis-parallel: 1/0 slabs
        direction.normalize();
        const float tMin = q % 3 == 0 ? 0.0f : 0.3f * rng.nextFloat();
        const float tMax = tMin + 2.5f * rng.nextFloat();
        std::vector<SphereHit> expected, fromBvh, fromEmbree;
        bruteForceSphereQuery(s.centres, s.radii, origin, direction, tMin, tMax, expected);
        bvh.query(origin, direction, tMin, tMax, fromBvh);
        embree.query(origin, direction, tMin, tMax, fromEmbree);
        expectSameHits(expected, fromBvh, "BVH", q);
        expectSameHits(expected, fromEmbree, "Embree", q);
        total += expected.size();
    }
    // Not vacuous: the segments cross many spheres in all.
    EXPECT_GT(total, 1000u);
}

TEST(SphereBvhTest, FindsExactlyTheSpheresBruteForceFindsWithOneRadius) {
    checkAgainstBruteForce(false);
}

TEST(SphereBvhTest, FindsExactlyTheSpheresBruteForceFindsWithPerSphereRadii) {
    checkAgainstBruteForce(true);
}

TEST(SphereBvhTest, TreesBuiltInParallelFindWhatBruteForceFinds) {
    // Large enough that subtrees are built as parallel tasks into precomputed node places, on
    // one thread and on several: every answer must still be brute force's.
    const Spheres s = randomSpheres(36000, true, 3);
    for (int threads : {1, 4}) {
        tbb::task_arena arena(threads);
        std::unique_ptr<SphereBvh> bvh;
        arena.execute([&] { bvh = std::make_unique<SphereBvh>(s.centres, s.radii); });
        Rng rng(8, 0, 0, StreamPurpose::Test);
        size_t total = 0;
        for (int q = 0; q < 30; ++q) {
            const Point3f origin(3.0f * rng.nextFloat() - 1.5f, 3.0f * rng.nextFloat() - 1.5f,
                                 3.0f * rng.nextFloat() - 1.5f);
            const Vector3f direction =
                Vector3f(rng.nextFloat() - 0.5f, rng.nextFloat() - 0.5f, rng.nextFloat() - 0.5f)
                    .normalized();
            std::vector<SphereHit> expected, actual;
            bruteForceSphereQuery(s.centres, s.radii, origin, direction, 0.0f, 3.0f, expected);
            bvh->query(origin, direction, 0.0f, 3.0f, actual);
            expectSameHits(expected, actual, "parallel BVH", q);
            total += expected.size();
        }
        EXPECT_GT(total, 1500u);
    }
}

TEST(SphereBvhTest, ClipsAtTheClosestPointNotAtTheSphere) {
    // Spheres of radius 0.5 on the z axis at z = 0.5, 1.2 and 2; segment t in [0.25, 1] from the
    // origin along +z. The sphere at 1.2 overlaps the segment's end but its closest point lies
    // beyond it (a photon behind a wall at t = 1): not crossed. The sphere at 0.5 contains the
    // whole segment: crossed (its entry and exit are both outside the segment).
    const std::vector<Point3f> centres = {Point3f(0, 0, 0.5f), Point3f(0, 0, 1.2f),
                                          Point3f(0, 0, 2.0f), Point3f(0.49f, 0, 0.6f),
                                          Point3f(0.51f, 0, 0.6f)};
    const std::vector<float> radii = {0.5f};
    const SphereBvh bvh(centres, radii);
    const EmbreeSphereIndex embree(centres, radii);
    for (int which = 0; which < 2; ++which) {
        std::vector<SphereHit> hits;
        if (which == 0)
            bvh.query(Point3f::Zero(), Vector3f(0, 0, 1), 0.25f, 1.0f, hits);
        else
            embree.query(Point3f::Zero(), Vector3f(0, 0, 1), 0.25f, 1.0f, hits);
        ASSERT_EQ(hits.size(), 2u) << which;
        EXPECT_EQ(hits[0].index, 0u);
        EXPECT_FLOAT_EQ(hits[0].t, 0.5f);
        EXPECT_EQ(hits[1].index, 3u);  // 0.49 off the axis: inside; 0.51: outside
        EXPECT_FLOAT_EQ(hits[1].t, 0.6f);
    }
}

TEST(SphereBvhTest, HitsAreSortedByDistanceThenIndex) {
    // The beam estimate walks the hits in this order; the fast path sorts (t, index) as 64-bit
    // integers, the general one (negative t, -0) by comparison: both must agree with a plain
    // sort, ties in t included.
    Rng rng(11, 0, 0, StreamPurpose::Test);
    for (int round = 0; round < 200; ++round) {
        std::vector<SphereHit> hits;
        const int count = 1 + round % 50;
        for (int i = 0; i < count; ++i) {
            float t = float(int(rng.nextFloat() * 8.0f)) * 0.25f;  // many ties
            if (round % 3 == 1) t -= 1.0f;                         // negative t
            if (round % 3 == 2 && i % 4 == 0) t = -0.0f;           // -0 among +0
            hits.push_back(SphereHit{static_cast<uint32_t>(rng.nextFloat() * 1000.0f), t});
        }
        std::vector<SphereHit> expected = hits;
        std::stable_sort(expected.begin(), expected.end(),
                         [](const SphereHit& a, const SphereHit& b) {
                             return a.t < b.t || (a.t == b.t && a.index < b.index);
                         });
        // Hits before `from` stay where they are.
        hits.insert(hits.begin(), SphereHit{7u, 5.0f});
        sortByDistance(hits, 1);
        ASSERT_EQ(hits.size(), expected.size() + 1);
        EXPECT_EQ(hits[0].index, 7u);
        for (size_t i = 0; i < expected.size(); ++i) {
            EXPECT_EQ(hits[i + 1].index, expected[i].index) << "round " << round;
            EXPECT_EQ(hits[i + 1].t, expected[i].t) << "round " << round;
        }
    }
}

TEST(SphereBvhTest, EmptyAndZeroRadiusSpheresAreNeverCrossed) {
    std::vector<SphereHit> hits;
    SphereBvh().query(Point3f::Zero(), Vector3f(1, 0, 0), 0.0f, 10.0f, hits);
    EXPECT_TRUE(hits.empty());
    const SphereBvh zero({Point3f(1, 0, 0)}, {0.0f});
    zero.query(Point3f::Zero(), Vector3f(1, 0, 0), 0.0f, 10.0f, hits);
    EXPECT_TRUE(hits.empty());
}

}  // namespace
}  // namespace alphorn
