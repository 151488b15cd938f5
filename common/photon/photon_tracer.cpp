#include "common/photon/photon_tracer.h"

#include "common/emitter/delta_light.h"
#include "common/scene/bsdf_query.h"
#include "common/scene/media_traversal.h"
#include "common/scene/scene.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <optional>
#include <utility>

namespace alphorn {

namespace {

// Photon indices per task. Fixed, so that the chunk a photon falls into (and with it the order
// of the concatenated output) never depends on threads.
constexpr uint64_t kChunk = 2048;

// Starts a photon path: an emitter chosen in proportion to its power, then its own emission
// sample. Returns false when nothing is emitted.
bool emitPhoton(const Scene& scene, Sampler& sampler, Ray3f& ray, Color3f& flux,
                const Emitter** chosen = nullptr) {
    float selection = sampler.next1D();
    const Point2f positionSample = sampler.next2D();
    const Point2f directionSample = sampler.next2D();
    float selectionPdf = 0.0f;
    const Emitter* emitter = scene.sampleEmitterByPower(selection, selectionPdf);
    if (chosen) *chosen = emitter;
    if (!emitter || !(selectionPdf > 0.0f)) return false;
    flux = emitter->samplePhoton(ray, positionSample, directionSample) / selectionPdf;
    return flux.isValid() && !flux.isBlack();
}

// Follows one photon path, appending the photons it stores to `out`.
void tracePhoton(const Scene& scene, Sampler& sampler, DirectPhotons direct, Photons& out) {
    Ray3f ray;
    Color3f flux;
    if (!emitPhoton(scene, sampler, ray, flux)) return;

    // Throughput relative to the emitted flux. Russian roulette keeps its largest channel
    // near 1, so the photons of a map carry nearly equal power (the best case for a density
    // estimate); 0.99 bounds the path length in closed scenes of albedo 1 (mirror boxes).
    Color3f throughput(1.0f);
    bool scattered = false;  // by any surface, null ones included (they block shadow rays)
    for (;;) {
        Intersection its;
        if (!scene.rayIntersect(ray, its)) return;
        const Vector3f dir = ray.d.normalized();
        const BSDF& bsdf = *its.mesh->bsdf();
        // Delta surfaces cannot be reached by a density estimate's BSDF evaluation (their eval
        // is zero), so a photon stored there would only cost memory.
        if (bsdf.isDiffuse() && (scattered || direct == DirectPhotons::Store))
            out.push_back(Photon{its.p, -dir, flux * throughput});
        scattered = true;

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

// The medium an emitted photon starts in: the side facing it of the first medium boundary along
// its ray (or, if none lies ahead, behind it). Without any boundary on that line, the camera's
// medium, which the bookkeeping of media_traversal.h gives every region no boundary declares
// (meshes without media keep the current one). Unlike mediumAt() this is right for area lights that
// sit on a medium boundary themselves: the line starts just off the light, along the emission.
const Medium* startMedium(const Scene& scene, const Ray3f& emitted) {
    for (const Vector3f& direction : {Vector3f(emitted.d), Vector3f(-emitted.d)}) {
        Ray3f ray(emitted.o, direction, Epsilon, Infinity);
        for (;;) {
            Intersection its;
            if (!scene.rayIntersect(ray, its)) break;
            if (its.mesh->hasMediumInterface())
                return its.mesh->mediumTowards(its, -ray.d, nullptr);
            ray = Ray3f(its.p, ray.d, Epsilon, Infinity);
        }
    }
    return scene.camera()->medium();
}

// The medium around each point-like light (point, spotlight, projector), found once per pass
// instead of once per photon: startMedium() traces one or more rays per photon (through every
// surface between the light and the first medium boundary), a large share of a photon path's
// rays in a scene like the stage. A light strictly inside a region sees that region's medium in
// every direction; one that sits on a boundary does not, so a light is cached only when 14
// directions (the axes and the cube's diagonals) all give the same medium. Area lights, whose
// photons start at different points, keep the per-photon search, except in a scene without any
// medium boundary, where every search ends at the camera's medium: there it costs nothing (the
// volumetric photon mapper without media then traces as fast as photonmapper, bench_feature_cost).
class StartMediumCache {
  public:
    explicit StartMediumCache(const Scene& scene) {
        m_anyBoundary =
            scene.findMesh([](const Mesh& mesh) { return mesh.hasMediumInterface(); }) != nullptr;
        if (!m_anyBoundary) return;
        for (const auto& emitter : scene.emitters()) {
            const auto* light = dynamic_cast<const DeltaPositionLight*>(emitter.get());
            if (!light) continue;
            std::optional<const Medium*> common;
            bool agree = true;
            for (int k = 0; k < 14 && agree; ++k) {
                Vector3f d = k < 6 ? Vector3f::Unit(k / 2) * (k % 2 ? -1.0f : 1.0f)
                                   : Vector3f(k & 1 ? 1.0f : -1.0f, k & 2 ? 1.0f : -1.0f,
                                              k & 4 ? 1.0f : -1.0f)
                                         .normalized();
                const Medium* medium = startMedium(scene, Ray3f(light->position(), d));
                if (common && *common != medium) agree = false;
                common = medium;
            }
            if (agree && common) m_media.emplace_back(emitter.get(), *common);
        }
    }

    // The medium an emitted photon starts in.
    const Medium* lookup(const Scene& scene, const Emitter* emitter, const Ray3f& ray) const {
        if (!m_anyBoundary) return scene.camera()->medium();
        for (const auto& [light, medium] : m_media)
            if (light == emitter) return medium;
        return startMedium(scene, ray);
    }

  private:
    bool m_anyBoundary = false;
    std::vector<std::pair<const Emitter*, const Medium*>> m_media;
};

// Where each kind of photon goes; nullptr: not stored for this path.
struct PhotonOutputs {
    Photons* surface = nullptr;
    Photons* volume = nullptr;
    std::vector<const Medium*>* volumeMedia = nullptr;  // beside `volume`
};

// tracePhoton() through media: the free-flight and phase sampling of volume.cpp's path loop, run
// from the light. The throughput carries spectral MIS for chromatic media (see MediumSample).
void tracePhotonThroughMedia(const Scene& scene, Sampler& sampler,
                             const Eigen::AlignedBox3f& mediaBox,
                             const StartMediumCache& startMedia, DirectPhotons direct,
                             const PhotonOutputs& out) {
    Ray3f emittedRay;
    Color3f flux;
    const Emitter* emitter = nullptr;
    if (!emitPhoton(scene, sampler, emittedRay, flux, &emitter)) return;
    const float length = emittedRay.d.norm();
    if (!(length > 0.0f)) return;
    // Unit direction: media measure distances in world units.
    Ray3f ray(emittedRay.o, emittedRay.d / length, emittedRay.mint * length,
              emittedRay.maxt * length);
    const Medium* medium = startMedia.lookup(scene, emitter, ray);
    if (emitter->isInfinite()) {
        // A photon from infinity starts on a disk outside the box media end at, with no surface
        // before the box: it starts where it enters the box, so that media attenuate it over the
        // same stretch as the camera rays that see the light directly and the shadow rays.
        float tNear, tFar;
        boxInterval(mediaBox, ray, tNear, tFar);
        if (!(tNear <= tFar)) return;  // misses the scene
        ray.o = ray(tNear);
    }
    Eigen::AlignedBox3f bounds = mediaBox;
    bounds.extend(ray.o);

    SpectralThroughput path;
    Color3f& throughput = path.throughput;
    bool scattered = false;  // by a medium or a non-null surface
    // Roulette after every scattering event, as tracePhoton() does: keeps photon powers near
    // equal and ends paths in closed scenes of albedo 1.
    auto survivesRoulette = [&]() {
        const float q = std::min(throughput.maxCoeff(), 0.99f);
        if (!(sampler.next1D() < q)) return false;
        throughput /= q;
        return true;
    };
    for (;;) {
        Intersection its;
        const bool hit = scene.rayIntersect(ray, its);
        if (isParticipating(medium)) {
            const float end = hit ? its.t : std::min(ray.maxt, exitDistance(bounds, ray));
            const MediumSample ms =
                medium->sampleDistance(Ray3f(ray.o, ray.d), end, sampler, path.hero);
            if (ms.event == MediumSample::Event::Absorbed) return;
            path.apply(ms);
            // A purely absorbing medium scatters with weight sigmaS = 0: nothing is stored.
            if (throughput.isBlack() || !throughput.allFinite()) return;
            if (ms.event == MediumSample::Event::Scattered) {
                if (out.volume) {
                    out.volume->push_back(Photon{ms.p, -ray.d, flux * throughput});
                    out.volumeMedia->push_back(medium);
                }
                scattered = true;
                Vector3f wo;
                const float weight = medium->phase().sample(-ray.d, wo, sampler.next2D());
                if (!(weight > 0.0f)) return;
                throughput *= weight;
                if (!survivesRoulette()) return;
                ray = Ray3f(ms.p, wo.normalized(), 0.0f, Infinity);
                continue;
            }
        }
        if (!hit) return;
        const Vector3f dir = ray.d;
        const BSDF& bsdf = *its.mesh->bsdf();
        if (bsdf.isNull()) {
            // An index-matched boundary: only the medium changes, no event, no random number.
            medium = its.mesh->mediumTowards(its, dir, medium);
            ray = Ray3f(its.p, dir, Epsilon, ray.maxt - its.t);
            continue;
        }
        if (out.surface && bsdf.isDiffuse() && (scattered || direct == DirectPhotons::Store))
            out.surface->push_back(Photon{its.p, -dir, flux * throughput});
        scattered = true;

        BSDFQueryRecord rec = makeBSDFQuery(its, its.toLocal(-dir));
        Color3f weight = bsdf.sample(rec, sampler.next2D());
        if (weight.isBlack() || !weight.allFinite()) return;
        weight *= rec.eta * rec.eta;  // flux, not radiance: see tracePhoton()
        throughput *= weight;
        if (!survivesRoulette()) return;
        const Vector3f wo = its.toWorld(rec.wo).normalized();
        medium = its.mesh->mediumTowards(its, wo, medium);
        ray = Ray3f(its.p, wo);
    }
}

// Concatenates per-chunk records in chunk order (and frees the chunks): the result is the same
// for any scheduling of the chunks.
template <typename Records>
Records concatenate(std::vector<Records>& chunks) {
    const size_t count = chunks.size();
    std::vector<size_t> offsets(count + 1, 0);
    for (size_t c = 0; c < count; ++c) offsets[c + 1] = offsets[c] + chunks[c].size();
    Records result(offsets[count]);
    tbb::parallel_for(size_t(0), count, [&](size_t c) {
        std::copy(chunks[c].begin(), chunks[c].end(), result.begin() + offsets[c]);
        Records().swap(chunks[c]);
    });
    return result;
}

}  // namespace

TracedPhotons tracePhotons(const Scene& scene, uint64_t seed, uint64_t pass, uint64_t count,
                           DirectPhotons direct) {
    TracedPhotons result;
    result.emitted = count;
    if (count == 0 || scene.emitters().empty()) return result;
    const uint64_t chunks = (count + kChunk - 1) / kChunk;
    std::vector<Photons> stored(chunks);
    tbb::parallel_for(uint64_t(0), chunks, [&](uint64_t c) {
        std::unique_ptr<Sampler> sampler = scene.sampler()->clone();
        // Filled here and moved in at the end: neighbouring chunks' vector headers share cache
        // lines, which two threads must not write at every photon.
        Photons out;
        const uint64_t end = std::min(count, (c + 1) * kChunk);
        out.reserve(2 * (end - c * kChunk));  // most paths store one or two photons
        for (uint64_t i = c * kChunk; i < end; ++i) {
            sampler->startStream(seed, pass, i, StreamPurpose::Photon);
            tracePhoton(scene, *sampler, direct, out);
        }
        stored[c] = std::move(out);
    });
    // Concatenate in chunk order: the map's content is the same for any scheduling.
    result.surface = concatenate(stored);
    return result;
}

TracedPhotons tracePhotonsThroughMedia(const Scene& scene, uint64_t seed, uint64_t pass,
                                       uint64_t surfaceCount, uint64_t volumeCount,
                                       DirectPhotons direct) {
    TracedPhotons result;
    result.emitted = surfaceCount;
    result.volumeEmitted = volumeCount;
    const uint64_t count = std::max(surfaceCount, volumeCount);
    if (count == 0 || scene.emitters().empty()) return result;
    const Eigen::AlignedBox3f mediaBox = mediaBounds(scene);
    const StartMediumCache startMedia(scene);
    const uint64_t chunks = (count + kChunk - 1) / kChunk;
    std::vector<Photons> surface(chunks), volume(chunks);
    std::vector<std::vector<const Medium*>> volumeMedia(chunks);
    tbb::parallel_for(uint64_t(0), chunks, [&](uint64_t c) {
        std::unique_ptr<Sampler> sampler = scene.sampler()->clone();
        // Filled here and moved in at the end (see tracePhotons).
        Photons chunkSurface, chunkVolume;
        std::vector<const Medium*> chunkVolumeMedia;
        const uint64_t end = std::min(count, (c + 1) * kChunk);
        for (uint64_t i = c * kChunk; i < end; ++i) {
            sampler->startStream(seed, pass, i, StreamPurpose::Photon);
            PhotonOutputs out;
            if (i < surfaceCount) out.surface = &chunkSurface;
            if (i < volumeCount) {
                out.volume = &chunkVolume;
                out.volumeMedia = &chunkVolumeMedia;
            }
            tracePhotonThroughMedia(scene, *sampler, mediaBox, startMedia, direct, out);
        }
        surface[c] = std::move(chunkSurface);
        volume[c] = std::move(chunkVolume);
        volumeMedia[c] = std::move(chunkVolumeMedia);
    });
    result.surface = concatenate(surface);
    result.volume = concatenate(volume);
    result.volumeMedia = concatenate(volumeMedia);
    return result;
}

}  // namespace alphorn
