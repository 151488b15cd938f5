// <integrator type="volumetric_photonmapper">: photon mapping with a surface and a volume photon
// map, the volume radiance estimated by the beam radiance estimate (Jarosz, Zwicker, Jensen
// 2008); fixed radii or k nearest neighbours; progressive mode with the Knaus–Zwicker schedule
// applied to both radii.
//
// Photons: one tracing loop (tracePhotonsThroughMedia) fills both maps. Photon paths fly through
// media by the media's own free-flight sampling and scatter by their phase functions; a photon is
// stored at every scattering event (volume map) and at every non-delta surface hit (surface
// map). Path i feeds the surface map when i < surfacePhotonCount and the volume map when
// i < volumePhotonCount, and each map's power is divided by its own count of paths (emitted, not
// stored; 64-bit).
//
// Camera paths: from the camera through delta surfaces to the first non-delta surface. Each
// straight piece of the path (through any index-matched, null, boundaries, which do not bend it)
// adds the beam estimate
//
//     L_b = Σ_i T(o → o + t_i d) · phase_i(−d, ω_i) · Φ_i / (π r_i²),
//
// over the volume photons i whose spheres of radius r_i the piece crosses (t_i, the parameter of
// the point closest to photon i, in [0, end of the piece]), phase_i the phase function of the
// medium photon i scattered in, and multiplies the path by the piece's transmittance; the
// non-delta surface at the end adds its photon density estimate. T is the media's own
// transmittance(): closed form for homogeneous media, ratio tracking for heterogeneous ones,
// walked once along the piece from photon to photon (a product of independent unbiased factors
// is unbiased). One query over the whole piece, rather than one per medium segment, keeps the
// photons near a medium's boundary whose closest points fall just outside it: a query per
// segment loses them (2% of the light of the agreement test's sphere).
//
// σs at the photon: the estimate is often written with a factor σs(x_i) Φ_i, for photons whose
// density estimates the fluence. Our stored Φ_i is the flux after the scattering event's weight,
// which already holds σs(x_i) (σs/σt at a homogeneous collision, whose density is σt·T; the
// collision's probability σs/μ in delta tracking), so Σ Φ_i / V estimates σs · fluence and no
// further factor belongs here. With one, media of varying σs come out wrong: the Perlin cases of
// volumetric_photonmapper_furnace_ttest.xml and the exponential sphere of
// volumetric_photonmapper_agreement_ttest.xml check it.
//
// Direct light is counted exactly once: photons carry all of it, single scattering included
// (no next-event estimation, as in photonmapper); emitters add their radiance only where a
// camera path sees them, attenuated by the media in between.
//
// Passes: as photonmapper. Without `progressive`, one pair of maps per (scene, seed), built from
// pass 0's streams; with it, pass i traces its own photons and gathers at the surface and volume
// radii of pass i from the one shared schedule (radius_schedule.h). radiusSchedule() reports the
// surface radius (the progress line shows one number; both follow the same ratio).
#include "common/integrator/direct.h"
#include "common/integrator/integrator.h"
#include "common/integrator/volume.h"
#include "common/photon/density_estimate.h"
#include "common/photon/photon_pass.h"
#include "common/photon/photon_tracer.h"
#include "common/photon/radius_schedule.h"
#include "common/scene/scene.h"

#include <absl/strings/str_format.h>

#include <mutex>

namespace alphorn {

class VolumetricPhotonMapper : public Integrator {
  public:
    explicit VolumetricPhotonMapper(const PropertyList& props) {
        const int count = props.getInteger("photonCount", 1000000);
        if (count <= 0)
            props.fail("\"photonCount\" (photon paths emitted per pass) must be positive, got %d",
                       count);
        m_surfaceCount = photonCount(props, "surfacePhotonCount", count);
        m_volumeCount = photonCount(props, "volumePhotonCount", count);

        m_surfaceRadiusGiven = props.has("surfacePhotonRadius");
        m_surfaceRadius = positiveRadius(props, "surfacePhotonRadius");
        m_volumeRadiusGiven = props.has("volumePhotonRadius");
        m_volumeRadius = positiveRadius(props, "volumePhotonRadius");
        m_surfaceK = neighbourCount(props, "surfaceK");
        m_volumeK = neighbourCount(props, "volumeK");

        m_progressive = props.getBoolean("progressive", false);
        const float alpha = props.getFloat("alpha", 0.5f);
        if (!isValidRadiusAlpha(alpha))
            props.fail(
                "\"alpha\" must be in (0, 1) (the fraction of photons kept per pass), got %g",
                alpha);
        m_alpha = alpha;
        // kNN radii adapt to each pass's photons; averaging passes of a kNN estimate does not
        // converge, so progressive mode needs fixed radii to shrink.
        if (m_progressive && (m_surfaceK > 0 || m_volumeK > 0))
            props.fail(
                "\"progressive\" shrinks fixed radii: use \"surfacePhotonRadius\" and "
                "\"volumePhotonRadius\", not \"%s\"",
                m_surfaceK > 0 ? "surfaceK" : "volumeK");
    }

    void preprocess(const Scene& scene) override {
        // Nori's default surface radius, 1/500 of the scene's diagonal; the volume default is
        // 1/100 (a beam crosses few photons at Nori's surface radius). kNN searches without a
        // given radius may reach across the whole scene.
        const float diagonal = scene.bounds().isEmpty() ? 1.0f : scene.bounds().diagonal().norm();
        if (!m_surfaceRadiusGiven) m_surfaceRadius = m_surfaceK > 0 ? diagonal : diagonal / 500.0f;
        if (!m_volumeRadiusGiven) m_volumeRadius = m_volumeK > 0 ? diagonal : diagonal / 100.0f;
        if (!(m_surfaceRadius > 0.0f && std::isfinite(m_surfaceRadius) && m_volumeRadius > 0.0f &&
              std::isfinite(m_volumeRadius)))
            fail(
                "cannot derive photon radii from the scene's bounds; give "
                "\"surfacePhotonRadius\" and \"volumePhotonRadius\"");
        m_mediaBox = mediaBounds(scene);
        m_hasMedia = sceneHasMedia(scene);
        std::lock_guard lock(m_cacheMutex);
        m_cached.reset();
    }

    std::shared_ptr<const PassData> preparePass(const Scene& scene, uint64_t seed,
                                                uint64_t pass) const override {
        if (m_progressive) {
            return trace(scene, seed, pass,
                         static_cast<float>(progressiveRadius(m_surfaceRadius, m_alpha, pass)),
                         static_cast<float>(progressiveRadius(m_volumeRadius, m_alpha, pass)));
        }
        // One pair of maps for all passes of a seed: built once, by whoever asks first.
        std::lock_guard lock(m_cacheMutex);
        if (!m_cached || m_cachedSeed != seed || m_cachedScene != &scene) {
            m_cached.reset();  // free the old maps before tracing the new ones
            m_cached = trace(scene, seed, 0, m_surfaceRadius, m_volumeRadius);
            m_cachedSeed = seed;
            m_cachedScene = &scene;
        }
        return m_cached;
    }

    std::optional<RadiusSchedule> radiusSchedule() const override {
        if (!m_progressive) return std::nullopt;
        return RadiusSchedule{m_surfaceRadius, m_alpha};
    }

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
               const PassData* passData) const override {
        const auto* data = dynamic_cast<const PhotonPassData*>(passData);
        if (!data) fail("volumetric_photonmapper: Li() needs the pass data of preparePass()");
        Color3f result(0.0f), throughput(1.0f);
        float etaScale = 1.0f;
        // Unit direction: media measure distances in world units.
        const float length = cameraRay.d.norm();
        if (!(length > 0.0f)) return result;
        Ray3f ray(cameraRay.o, cameraRay.d / length, cameraRay.mint * length,
                  cameraRay.maxt * length);
        const Medium* medium = scene.camera()->medium();
        Eigen::AlignedBox3f bounds = m_mediaBox;
        bounds.extend(cameraRay.o);
        thread_local StraightPath line;
        for (int depth = 0;;) {
            Intersection its;
            const bool hit = walkStraight(scene, ray, bounds, medium, line, its);
            // Beam estimate and emission of null surfaces along the line, then its transmittance.
            result += throughput * lineRadiance(*data, line, hit ? &its : nullptr, sampler);
            throughput *= line.transmittance;
            if (!hit || throughput.isBlack()) break;

            const Vector3f dir = ray.d;
            result += throughput * emittedRadiance(its.p - its.t * dir, dir, its);
            const BSDF& bsdf = *its.mesh->bsdf();
            const Vector3f wi = its.toLocal(-dir);
            if (bsdf.isDiffuse()) {
                result += throughput * reflectedRadiance(*data, its, bsdf, wi);
                break;
            }
            // A delta chain: follow it. Roulette (not a cap) ends chains between mirrors.
            if (depth++ >= 3) {
                const float q = std::min(throughput.maxCoeff() * etaScale, 0.99f);
                if (!(sampler.next1D() < q)) break;
                throughput /= q;
            }
            BSDFQueryRecord rec = makeBSDFQuery(its, wi);
            const Color3f weight = bsdf.sample(rec, sampler.next2D());
            if (weight.isBlack() || !weight.allFinite()) break;
            throughput *= weight;
            etaScale *= rec.eta * rec.eta;
            const Vector3f wo = its.toWorld(rec.wo).normalized();
            medium = its.mesh->mediumTowards(its, wo, medium);
            ray = Ray3f(its.p, wo);
        }
        return result;
    }

    std::string toString() const override {
        auto lookup = [](int k, float radius) {
            return k > 0 ? absl::StrFormat("%d nearest neighbours within %g", k, radius)
                         : absl::StrFormat("radius %g", radius);
        };
        return absl::StrFormat(
            "volumetric_photonmapper (%u surface and %u volume photon paths per pass; surface %s; "
            "volume %s%s)",
            m_surfaceCount, m_volumeCount, lookup(m_surfaceK, m_surfaceRadius),
            lookup(m_volumeK, m_volumeRadius),
            m_progressive ? absl::StrFormat("; progressive, alpha %g", m_alpha) : "");
    }

  private:
    static uint64_t photonCount(const PropertyList& props, const std::string& name, int fallback) {
        const int count = props.getInteger(name, fallback);
        if (count < 0)
            props.fail("\"%s\" (photon paths per pass) must be at least 0, got %d", name, count);
        return static_cast<uint64_t>(count);
    }

    static float positiveRadius(const PropertyList& props, const std::string& name) {
        const float radius = props.getFloat(name, 0.0f);
        if (props.has(name) && !(radius > 0.0f && std::isfinite(radius)))
            props.fail("\"%s\" must be positive and finite, got %g", name, radius);
        return radius;
    }

    static int neighbourCount(const PropertyList& props, const std::string& name) {
        const int k = props.getInteger(name, 0);
        if (props.has(name) && k < 2) props.fail("\"%s\" must be at least 2, got %d", name, k);
        return k;
    }

    // Does any light interaction happen in a medium? Without, no volume photon is traced.
    static bool sceneHasMedia(const Scene& scene) {
        if (isParticipating(scene.camera()->medium())) return true;
        for (const auto& mesh : scene.meshes())
            if (isParticipating(mesh->insideMedium()) || isParticipating(mesh->outsideMedium()))
                return true;
        return false;
    }

    std::shared_ptr<const PhotonPassData> trace(const Scene& scene, uint64_t seed, uint64_t pass,
                                                float surfaceRadius, float volumeRadius) const {
        const uint64_t volumeCount = m_hasMedia ? m_volumeCount : 0;
        TracedPhotons traced =
            tracePhotonsThroughMedia(scene, seed, pass, m_surfaceCount, volumeCount);
        auto data = std::make_shared<PhotonPassData>();
        data->surface = PhotonMap(
            std::move(traced.surface),
            m_surfaceK > 0 ? PhotonMap::Lookup::Nearest : PhotonMap::Lookup::Radius, surfaceRadius);
        data->emitted = traced.emitted;
        data->powerScale = traced.emitted > 0 ? 1.0 / static_cast<double>(traced.emitted) : 0.0;
        data->surfaceRadius = surfaceRadius;
        if (!traced.volume.empty())
            data->volume =
                m_volumeK > 0
                    ? VolumePhotonMap(std::move(traced.volume), std::move(traced.volumeMedia),
                                      static_cast<size_t>(m_volumeK), volumeRadius)
                    : VolumePhotonMap(std::move(traced.volume), std::move(traced.volumeMedia),
                                      volumeRadius);
        data->volumeEmitted = traced.volumeEmitted;
        data->volumePowerScale =
            traced.volumeEmitted > 0 ? 1.0 / static_cast<double>(traced.volumeEmitted) : 0.0;
        data->volumeRadius = volumeRadius;
        return data;
    }

    // A straight piece of a camera path: from `origin` along `direction` through null
    // (index-matched) boundaries, which change the medium but not the direction, to the first
    // other surface, or to where the ray leaves the media box. t is measured from `origin`.
    struct StraightPath {
        struct Span {
            float start, end;
            const Medium* medium;
        };
        struct Emission {
            float t;
            Color3f radiance;
        };
        Point3f origin;
        Vector3f direction;
        float end = 0.0f;
        std::vector<Span> spans;          // the participating media along it, by increasing t
        std::vector<Emission> emissions;  // emitting null surfaces crossed
        std::vector<SphereHit> hits;      // scratch for the beam query
        Color3f transmittance;            // over [0, end], set by lineRadiance()
    };

    // Walks `ray` through null boundaries (updating `medium`), filling `line`; returns whether it
    // ends at a surface, then `its` (with its.t measured from the last crossing).
    static bool walkStraight(const Scene& scene, const Ray3f& ray,
                             const Eigen::AlignedBox3f& bounds, const Medium*& medium,
                             StraightPath& line, Intersection& its) {
        line.origin = ray.o;
        line.direction = ray.d;
        line.spans.clear();
        line.emissions.clear();
        float base = 0.0f;  // t of the current piece's origin
        Ray3f piece = ray;
        for (;;) {
            const bool hit = scene.rayIntersect(piece, its);
            const float end = hit ? its.t : std::min(piece.maxt, exitDistance(bounds, piece));
            if (isParticipating(medium)) line.spans.push_back({base, base + end, medium});
            line.end = base + end;
            if (!hit || !its.mesh->bsdf()->isNull()) return hit;
            const Color3f emitted = emittedRadiance(piece.o, piece.d, its);
            if (!emitted.isBlack()) line.emissions.push_back({base + its.t, emitted});
            medium = its.mesh->mediumTowards(its, piece.d, medium);
            base += its.t;
            piece = Ray3f(its.p, piece.d, Epsilon, piece.maxt - its.t);
        }
    }

    // The beam radiance estimate along the whole straight line, plus the emission of the null
    // surfaces on it, each times the transmittance from the line's origin; sets
    // line.transmittance to the whole line's. One query over [0, end] finds every photon sphere
    // the line crosses, whichever medium the photon scattered in (its own phase function
    // applies): a photon near a boundary is found from either side, so no energy is lost where a
    // medium's boundary cuts the photons' discs. Photons are visited by increasing t (ties by
    // index), in an order fixed by the photon array alone, so that one transmittance walk, which
    // multiplies independent unbiased estimates of consecutive pieces, serves them all.
    //
    // No light leaks through walls: photons whose closest point lies beyond `end` are out by the
    // query's clip, but a line meeting a wall obliquely passes photons just behind it at closest
    // points before `end`. When a surface ends the line (`wall`), photons on the far side of its
    // tangent plane are left out too.
    Color3f lineRadiance(const PhotonPassData& data, StraightPath& line, const Intersection* wall,
                         Sampler& sampler) const {
        line.transmittance = Color3f(1.0f);
        if (line.spans.empty() && line.emissions.empty()) return Color3f(0.0f);
        Color3f& transmittance = line.transmittance;
        size_t span = 0;
        float walked = 0.0f;
        auto walkTo = [&](float t) {
            while (walked < t && span < line.spans.size()) {
                const StraightPath::Span& s = line.spans[span];
                const float from = std::max(walked, s.start), to = std::min(t, s.end);
                if (to > from && !transmittance.isBlack())
                    transmittance *= s.medium->transmittance(
                        Ray3f(line.origin + from * line.direction, line.direction), to - from,
                        sampler);
                if (t < s.end) break;
                walked = s.end;
                ++span;
            }
            walked = std::max(walked, t);
        };

        line.hits.clear();
        if (!line.spans.empty() && !data.volume.empty())
            data.volume.crossedBy(line.origin, line.direction, 0.0f, line.end, line.hits);
        std::sort(line.hits.begin(), line.hits.end(), [](const SphereHit& a, const SphereHit& b) {
            return a.t < b.t || (a.t == b.t && a.index < b.index);
        });
        const float cameraSide = wall ? (line.origin - wall->p).dot(wall->geoFrame.n) : 0.0f;
        const std::vector<Photon>& photons = data.volume.photons();
        Color3f beam(0.0f), emitted(0.0f);
        size_t next = 0;
        auto emitUpTo = [&](float t) {
            for (; next < line.emissions.size() && line.emissions[next].t <= t; ++next) {
                walkTo(line.emissions[next].t);
                emitted += transmittance * line.emissions[next].radiance;
            }
        };
        for (const SphereHit& hit : line.hits) {
            emitUpTo(hit.t);
            const Photon& photon = photons[hit.index];
            const Medium* medium = data.volume.medium(hit.index);
            if (!medium) continue;
            if (wall && (photon.position - wall->p).dot(wall->geoFrame.n) * cameraSide < 0.0f)
                continue;
            walkTo(hit.t);
            if (transmittance.isBlack()) break;
            const float r = data.volume.radius(hit.index);
            const float phase = medium->phase().eval(-line.direction, photon.direction);
            beam += transmittance * photon.power *
                    static_cast<float>(phase / (M_PI * double(r) * double(r)));
        }
        emitUpTo(Infinity);
        walkTo(line.end);
        return beam * static_cast<float>(data.volumePowerScale) + emitted;
    }

    // Radiance leaving a non-delta surface towards the camera, from the surface photons (as in
    // photonmapper.cpp).
    Color3f reflectedRadiance(const PhotonPassData& data, const Intersection& its, const BSDF& bsdf,
                              const Vector3f& wi) const {
        if (data.surface.empty()) return Color3f(0.0f);
        BSDFQueryRecord rec = makeBSDFQuery(its, wi);
        rec.measure = Measure::SolidAngle;
        // The photon power density already holds the cosine at the surface: no cos here.
        auto weight = [&](const Photon& photon) {
            rec.wo = its.toLocal(photon.direction);
            return Color3f(bsdf.eval(rec) * photon.power);
        };
        const Color3f density =
            m_surfaceK > 0
                ? nearestNeighbourEstimate(data.surface, its.p, static_cast<size_t>(m_surfaceK),
                                           data.surfaceRadius, weight)
                : fixedRadiusEstimate(data.surface, its.p, data.surfaceRadius, weight);
        return density * static_cast<float>(data.powerScale);
    }

    uint64_t m_surfaceCount = 0, m_volumeCount = 0;
    float m_surfaceRadius = 0.0f, m_volumeRadius = 0.0f;
    bool m_surfaceRadiusGiven = false, m_volumeRadiusGiven = false;
    int m_surfaceK = 0, m_volumeK = 0;
    bool m_progressive = false;
    double m_alpha = 0.5;
    Eigen::AlignedBox3f m_mediaBox;
    bool m_hasMedia = false;

    mutable std::mutex m_cacheMutex;
    mutable std::shared_ptr<const PhotonPassData> m_cached;
    mutable uint64_t m_cachedSeed = 0;
    mutable const Scene* m_cachedScene = nullptr;
};

ALPHORN_REGISTER(Integrator, "volumetric_photonmapper", VolumetricPhotonMapper);

}  // namespace alphorn
