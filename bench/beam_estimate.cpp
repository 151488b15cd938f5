// Beam radiance estimate benchmark: which index answers "which photon spheres does this camera
// ray segment cross?" faster -- Embree's BVH over user-geometry spheres (the well-kept library,
// and the baseline) or our own BVH of spheres (common/photon/sphere_bvh.h) with leaves of 2, 4
// and 8 spheres.
//
// Identical volume photons (traced by the volumetric photon mapper's own tracer from the scene)
// and identical query segments (camera rays through random image positions, from the camera
// through null boundaries to their first other hit or the end of the media box, as the integrator
// queries them), single-threaded. Within a round the indexes take
// turns on blocks of 2000 segments, so that a change in the machine's load hits all alike, and
// every index must return the same hits as Embree (indices and t, checked). Printed per round
// and as medians: the query-rate ratio BVH / Embree, measured in the same run (these machines
// are noisy: only same-run ratios are worth comparing), plus build times.
//
// Radii: the fixed radii diagonal/200 and diagonal/50, and per-photon radii from the 10 nearest
// volume photons (volumeK = 10).
//
// usage: bench_beam_estimate [SCENE.xml] [photon paths] [rounds]
#include "bench/timing.h"
#include "common/core/rng.h"
#include "common/integrator/volume.h"
#include "common/photon/photon_tracer.h"
#include "common/photon/sphere_bvh.h"
#include "common/photon/volume_photon_map.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <tbb/info.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>

using namespace alphorn;
using bench::median;
using bench::seconds;

namespace {

struct Segment {
    Point3f origin;
    Vector3f direction;
    float end;
};

// Camera rays through random image positions, each up to its first non-null hit (or the media
// box).
std::vector<Segment> cameraSegments(const Scene& scene, size_t count) {
    const Camera& camera = *scene.camera();
    const Vector2f size = camera.outputSize().cast<float>();
    const Eigen::AlignedBox3f box = mediaBounds(scene);
    std::vector<Segment> segments;
    for (uint64_t i = 0; i < count; ++i) {
        Rng rng(99, 0, i, StreamPurpose::Test);
        Ray3f ray;
        const float u = rng.nextFloat(), v = rng.nextFloat();
        camera.sampleRay(ray, Point2f(u * size.x(), v * size.y()), Point2f(0.5f, 0.5f));
        ray.d.normalize();
        // Through null boundaries, as the integrator's one query per straight line does.
        float end = 0.0f;
        Ray3f piece = ray;
        for (;;) {
            Intersection its;
            if (!scene.rayIntersect(piece, its)) {
                end += exitDistance(box, piece);
                break;
            }
            end += its.t;
            if (!its.mesh->bsdf()->isNull()) break;
            piece = Ray3f(its.p, piece.d);
        }
        segments.push_back(Segment{ray.o, ray.d, end});
    }
    return segments;
}

struct QueryResult {
    double seconds = 0.0;
    uint64_t hits = 0;
    uint64_t checksum = 0;  // of indices and t bits, so that equal answers are checked cheaply
};

template <typename Index>
QueryResult run(const Index& index, const std::vector<Segment>& segments, size_t begin,
                size_t end) {
    QueryResult r;
    std::vector<SphereHit> hits;
    const auto start = std::chrono::steady_clock::now();
    for (size_t s = begin; s < end; ++s) {
        hits.clear();
        index.query(segments[s].origin, segments[s].direction, 0.0f, segments[s].end, hits);
        r.hits += hits.size();
        for (const SphereHit& h : hits) {
            uint32_t bits;
            std::memcpy(&bits, &h.t, sizeof bits);
            r.checksum = r.checksum * 1000003u + h.index * 31u + bits;
        }
    }
    r.seconds = seconds(start);
    return r;
}

}  // namespace

int main(int argc, char** argv) {
    const std::string scenePath =
        argc > 1 ? argv[1] : sourcePath("scenes/seed/medium_sphere_vpm.xml");
    const uint64_t photonPaths = argc > 2 ? std::stoull(argv[2]) : 100000;
    const int rounds = argc > 3 ? std::stoi(argv[3]) : 3;
    try {
        std::shared_ptr<Scene> scene = loadScene(scenePath);
        const float diagonal = scene->bounds().diagonal().norm();
        const TracedPhotons traced = tracePhotonsThroughMedia(*scene, 1, 0, 0, photonPaths);
        std::vector<Point3f> centres;
        for (const Photon& p : traced.volume) centres.push_back(p.position);
        const std::vector<Segment> segments = cameraSegments(*scene, 40000);
        std::printf(
            "scene %s: %llu photon paths, %zu volume photons, %zu segments, %d rounds, "
            "%d cores (queries single-threaded)\n",
            scenePath.c_str(), static_cast<unsigned long long>(photonPaths), centres.size(),
            segments.size(), rounds, tbb::info::default_concurrency());
        if (centres.empty()) {
            std::fprintf(stderr, "the scene stores no volume photons\n");
            return 1;
        }
        // The kNN radii of the volume map itself.
        const VolumePhotonMap knn(traced.volume, {}, 10, diagonal / 10.0f);
        std::vector<float> knnRadii(centres.size());
        for (uint32_t i = 0; i < centres.size(); ++i) knnRadii[i] = knn.radius(i);

        struct Setting {
            std::string name;
            std::vector<float> radii;
        };
        const std::vector<Setting> settings = {
            {"radius diagonal/200", {diagonal / 200.0f}},
            {"radius diagonal/50", {diagonal / 50.0f}},
            {"10 nearest neighbours", knnRadii},
        };
        const uint32_t leaves[3] = {2, 4, 8};
        for (const Setting& setting : settings) {
            std::vector<double> ratios[3], embreeRates, embreeBuild, bvhBuild;
            uint64_t hits = 0;
            for (int round = 0; round < rounds; ++round) {
                auto start = std::chrono::steady_clock::now();
                const EmbreeSphereIndex embree(centres, setting.radii);
                embreeBuild.push_back(seconds(start));
                std::vector<std::unique_ptr<SphereBvh>> bvhs;
                for (uint32_t leaf : leaves) {
                    start = std::chrono::steady_clock::now();
                    bvhs.push_back(std::make_unique<SphereBvh>(centres, setting.radii, leaf));
                    if (leaf == 8) bvhBuild.push_back(seconds(start));
                }
                QueryResult e, b[3];
                constexpr size_t kBlock = 2000;
                for (size_t from = 0; from < segments.size(); from += kBlock) {
                    const size_t to = std::min(segments.size(), from + kBlock);
                    const QueryResult eb = run(embree, segments, from, to);
                    e.seconds += eb.seconds, e.hits += eb.hits;
                    e.checksum = e.checksum * 7u + eb.checksum;
                    for (int l = 0; l < 3; ++l) {
                        const QueryResult bb = run(*bvhs[l], segments, from, to);
                        b[l].seconds += bb.seconds, b[l].hits += bb.hits;
                        b[l].checksum = b[l].checksum * 7u + bb.checksum;
                    }
                }
                for (int l = 0; l < 3; ++l) {
                    if (b[l].hits != e.hits || b[l].checksum != e.checksum) {
                        std::fprintf(
                            stderr, "MISMATCH: BVH (leaf %u) found %llu hits, Embree %llu\n",
                            leaves[l], (unsigned long long)b[l].hits, (unsigned long long)e.hits);
                        return 1;
                    }
                    ratios[l].push_back(e.seconds / b[l].seconds);
                }
                hits = e.hits;
                embreeRates.push_back(segments.size() / e.seconds);
                std::printf(
                    "%s, round %d: Embree %.0f segments/s; BVH / Embree rate: leaf 2 %.3f, leaf 4 "
                    "%.3f, leaf 8 %.3f\n",
                    setting.name.c_str(), round, embreeRates.back(), ratios[0].back(),
                    ratios[1].back(), ratios[2].back());
            }
            std::printf(
                "%s (%.1f spheres per segment): Embree median %.0f segments/s; median BVH / Embree "
                "query rate: leaf 2 %.3f, leaf 4 %.3f, leaf 8 %.3f; build Embree %.1f ms, BVH "
                "(leaf 8) %.1f ms\n",
                setting.name.c_str(), double(hits) / segments.size(), median(embreeRates),
                median(ratios[0]), median(ratios[1]), median(ratios[2]), median(embreeBuild) * 1e3,
                median(bvhBuild) * 1e3);
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
    return 0;
}
