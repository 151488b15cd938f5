#include "common/photon/photon_tracer.h"

#include "common/integrator/direct.h"
#include "common/scene/scene.h"

#include <tbb/parallel_for.h>

namespace alphorn {

namespace {

// Photon indices per task. Fixed, so that the chunk a photon falls into (and with it the order
// of the concatenated output) never depends on threads.
constexpr uint64_t kChunk = 2048;

// Follows one photon path, appending the photons it stores to `out`.
void tracePhoton(const Scene& scene, Sampler& sampler, std::vector<Photon>& out) {
    float selection = sampler.next1D();
    const Point2f positionSample = sampler.next2D();
    const Point2f directionSample = sampler.next2D();
    float selectionPdf = 0.0f;
    const Emitter* emitter = scene.sampleEmitterByPower(selection, selectionPdf);
    if (!emitter || !(selectionPdf > 0.0f)) return;
    Ray3f ray;
    const Color3f flux = emitter->samplePhoton(ray, positionSample, directionSample) / selectionPdf;
    if (!flux.isValid() || flux.isBlack()) return;

    // Throughput relative to the emitted flux. Russian roulette keeps its largest channel
    // near 1, so the photons of a map carry nearly equal power (the best case for a density
    // estimate); 0.99 bounds the path length in closed scenes of albedo 1 (mirror boxes).
    Color3f throughput(1.0f);
    for (;;) {
        Intersection its;
        if (!scene.rayIntersect(ray, its)) return;
        const Vector3f dir = ray.d.normalized();
        const BSDF& bsdf = *its.mesh->bsdf();
        // Delta surfaces cannot be reached by a density estimate's BSDF evaluation (their eval
        // is zero), so a photon stored there would only cost memory.
        if (bsdf.isDiffuse()) out.push_back(Photon{its.p, -dir, flux * throughput});

        BSDFQueryRecord rec = makeBSDFQuery(its, its.toLocal(-dir));
        Color3f weight = bsdf.sample(rec, sampler.next2D());
        if (weight.isBlack() || !weight.allFinite()) return;
        // BSDF sampling weights are written for radiance, which a refraction scales by 1/eta²
        // (the dielectric's weight). Photons carry flux, which a refraction does not scale:
        // undo it (eta is 1 for reflections).
        weight *= rec.eta * rec.eta;
        throughput *= weight;
        const float q = std::min(throughput.maxCoeff(), 0.99f);
        if (!(sampler.next1D() < q)) return;
        throughput /= q;
        ray = Ray3f(its.p, its.toWorld(rec.wo));
    }
}

}  // namespace

TracedPhotons tracePhotons(const Scene& scene, uint64_t seed, uint64_t pass, uint64_t count) {
    TracedPhotons result;
    result.emitted = count;
    if (count == 0 || scene.emitters().empty()) return result;
    const uint64_t chunks = (count + kChunk - 1) / kChunk;
    std::vector<std::vector<Photon>> stored(chunks);
    tbb::parallel_for(uint64_t(0), chunks, [&](uint64_t c) {
        std::unique_ptr<Sampler> sampler = scene.sampler()->clone();
        std::vector<Photon>& out = stored[c];
        const uint64_t end = std::min(count, (c + 1) * kChunk);
        out.reserve(2 * (end - c * kChunk));  // most paths store one or two photons
        for (uint64_t i = c * kChunk; i < end; ++i) {
            sampler->startStream(seed, pass, i, StreamPurpose::Photon);
            tracePhoton(scene, *sampler, out);
        }
    });
    // Concatenate in chunk order: the map's content is the same for any scheduling.
    std::vector<size_t> offsets(chunks + 1, 0);
    for (uint64_t c = 0; c < chunks; ++c) offsets[c + 1] = offsets[c] + stored[c].size();
    result.surface.resize(offsets[chunks]);
    tbb::parallel_for(uint64_t(0), chunks, [&](uint64_t c) {
        std::copy(stored[c].begin(), stored[c].end(), result.surface.begin() + offsets[c]);
        std::vector<Photon>().swap(stored[c]);
    });
    return result;
}

}  // namespace alphorn
