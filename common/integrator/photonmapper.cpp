// <integrator type="photonmapper">: surface photon mapping (Jensen), and progressive photon
// mapping with the Knaus–Zwicker radius schedule.
//
// Photons: `photonCount` photon paths are emitted per photon pass, from emitters chosen in
// proportion to their power (common/photon/photon_tracer.h), and stored at non-delta surfaces;
// their power is divided by the number emitted, never by the number stored.
// Camera paths: from the camera through any chain of delta (mirror, glass, null) surfaces to the
// first non-delta hit, where the reflected radiance is the photon density estimate, and
// emission is added wherever the path hits an emitter. Direct light is counted exactly once:
// photons carry all of it (no next-event estimation), so the image is the photon estimate plus
// the emitters seen directly or through delta surfaces.
//
// Passes: without `progressive`, every pass reads one photon map, traced once per (scene, seed)
// from pass 0's photon streams, with a fixed radius or k nearest neighbours; more passes
// average camera noise only (classic photon mapping). With `progressive`, pass i traces its own
// photons (streams of pass i) and gathers at r_i from the one shared schedule
// (common/photon/radius_schedule.h); the image, the average of the passes, converges.
#include "common/integrator/direct.h"
#include "common/integrator/integrator.h"
#include "common/photon/density_estimate.h"
#include "common/photon/photon_pass.h"
#include "common/photon/photon_tracer.h"
#include "common/photon/radius_schedule.h"

#include <absl/strings/str_format.h>

#include <mutex>

namespace alphorn {

class PhotonMapper : public Integrator {
  public:
    explicit PhotonMapper(const PropertyList& props) {
        // Nori's default photon count; photons EMITTED per photon pass (see docs).
        const int count = props.getInteger("photonCount", 1000000);
        if (count <= 0)
            props.fail("\"photonCount\" (photons emitted per pass) must be positive, got %d",
                       count);
        m_photonCount = static_cast<uint64_t>(count);
        m_radiusGiven = props.has("surfacePhotonRadius");
        m_radius = props.getFloat("surfacePhotonRadius", 0.0f);
        if (m_radiusGiven && !(m_radius > 0.0f && std::isfinite(m_radius)))
            props.fail("\"surfacePhotonRadius\" must be positive and finite, got %g", m_radius);
        m_k = props.getInteger("surfaceK", 0);
        if (props.has("surfaceK") && m_k < 2)
            props.fail("\"surfaceK\" must be at least 2 (the estimate divides by k - 1), got %d",
                       m_k);
        m_progressive = props.getBoolean("progressive", false);
        const float alpha = props.getFloat("alpha", 0.5f);
        if (!isValidRadiusAlpha(alpha))
            props.fail(
                "\"alpha\" must be in (0, 1) (the fraction of photons kept per pass), got %g",
                alpha);
        m_alpha = alpha;
        if (m_progressive && m_k > 0)
            props.fail(
                "\"progressive\" shrinks a fixed radius: use \"surfacePhotonRadius\", not "
                "\"surfaceK\"");
    }

    void preprocess(const Scene& scene) override {
        // Nori's default radius: 1/500 of the scene's diagonal. A kNN search without a given
        // radius may reach across the whole scene.
        const float diagonal = scene.bounds().isEmpty() ? 1.0f : scene.bounds().diagonal().norm();
        if (!m_radiusGiven) m_radius = m_k > 0 ? diagonal : diagonal / 500.0f;
        if (!(m_radius > 0.0f && std::isfinite(m_radius)))
            fail(
                "cannot derive a photon radius from the scene's bounds; give "
                "\"surfacePhotonRadius\"");
        std::lock_guard lock(m_cacheMutex);
        m_cached.reset();
    }

    std::shared_ptr<const PassData> preparePass(const Scene& scene, uint64_t seed,
                                                uint64_t pass) const override {
        if (m_progressive) {
            const RadiusSchedule schedule = *radiusSchedule();
            const float radius =
                static_cast<float>(progressiveRadius(schedule.initialRadius, schedule.alpha, pass));
            return trace(scene, seed, pass, radius);
        }
        // One photon map for all passes of a seed: build it once, whoever asks first.
        std::lock_guard lock(m_cacheMutex);
        if (!m_cached || m_cachedSeed != seed || m_cachedScene != &scene) {
            m_cached.reset();  // free the old map before tracing the new one
            m_cached = trace(scene, seed, 0, m_radius);
            m_cachedSeed = seed;
            m_cachedScene = &scene;
        }
        return m_cached;
    }

    std::optional<RadiusSchedule> radiusSchedule() const override {
        if (!m_progressive) return std::nullopt;
        return RadiusSchedule{m_radius, m_alpha};
    }

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
               const PassData* passData) const override {
        const auto* data = dynamic_cast<const PhotonPassData*>(passData);
        if (!data) fail("photonmapper: Li() needs the pass data of preparePass()");
        Color3f result(0.0f), throughput(1.0f);
        float etaScale = 1.0f;
        Ray3f ray = cameraRay;
        for (int depth = 0;; ++depth) {
            Intersection its;
            if (!scene.rayIntersect(ray, its)) break;
            const Vector3f dir = ray.d.normalized();
            result += throughput * emittedRadiance(ray.o, dir, its);
            const BSDF& bsdf = *its.mesh->bsdf();
            const Vector3f wi = its.toLocal(-dir);
            if (bsdf.isDiffuse()) {
                result += throughput * reflectedRadiance(*data, its, bsdf, wi);
                break;
            }
            // A delta chain: follow it. Roulette (not a cap) ends chains between mirrors.
            if (depth >= 3) {
                const float q = std::min(throughput.maxCoeff() * etaScale, 0.99f);
                if (!(sampler.next1D() < q)) break;
                throughput /= q;
            }
            BSDFQueryRecord rec = makeBSDFQuery(its, wi);
            const Color3f weight = bsdf.sample(rec, sampler.next2D());
            if (weight.isBlack() || !weight.allFinite()) break;
            throughput *= weight;
            etaScale *= rec.eta * rec.eta;
            ray = Ray3f(its.p, its.toWorld(rec.wo));
        }
        return result;
    }

    std::string toString() const override {
        return absl::StrFormat(
            "photonmapper (%u photons per pass, %s, radius %g%s)", m_photonCount,
            m_k > 0 ? absl::StrFormat("%d nearest neighbours", m_k) : "fixed radius", m_radius,
            m_progressive ? absl::StrFormat(", progressive, alpha %g", m_alpha) : "");
    }

  private:
    std::shared_ptr<const PhotonPassData> trace(const Scene& scene, uint64_t seed, uint64_t pass,
                                                float radius) const {
        TracedPhotons traced = tracePhotons(scene, seed, pass, m_photonCount);
        auto data = std::make_shared<PhotonPassData>();
        data->surface =
            PhotonMap(std::move(traced.surface),
                      m_k > 0 ? PhotonMap::Lookup::Nearest : PhotonMap::Lookup::Radius, radius);
        data->powerScale = 1.0 / static_cast<double>(traced.emitted);
        data->emitted = traced.emitted;
        data->surfaceRadius = radius;
        return data;
    }

    // Radiance leaving a non-delta surface towards the camera, estimated from the photons.
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
            m_k > 0 ? nearestNeighbourEstimate(data.surface, its.p, static_cast<size_t>(m_k),
                                               data.surfaceRadius, weight)
                    : fixedRadiusEstimate(data.surface, its.p, data.surfaceRadius, weight);
        return density * static_cast<float>(data.powerScale);
    }

    uint64_t m_photonCount;
    float m_radius;
    bool m_radiusGiven;
    int m_k;
    bool m_progressive;
    double m_alpha;

    mutable std::mutex m_cacheMutex;
    mutable std::shared_ptr<const PhotonPassData> m_cached;
    mutable uint64_t m_cachedSeed = 0;
    mutable const Scene* m_cachedScene = nullptr;
};

ALPHORN_REGISTER(Integrator, "photonmapper", PhotonMapper);

}  // namespace alphorn
