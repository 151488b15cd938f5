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
#include "common/integrator/photon_mapping.h"
#include "common/photon/photon_tracer.h"

#include <absl/strings/str_format.h>

namespace alphorn {

class PhotonMapper : public PhotonMappingIntegrator {
  public:
    explicit PhotonMapper(const PropertyList& props) : PhotonMappingIntegrator(props) {}

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
               const PassData* passData) const override {
        const PhotonPassData& data = photonPassData(passData);
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
                result += throughput * reflectedRadiance(data, its, bsdf, wi);
                break;
            }
            const auto wo = followDeltaChain(its, wi, depth, sampler, throughput, etaScale);
            if (!wo) break;
            ray = Ray3f(its.p, *wo);
        }
        return result;
    }

    std::string toString() const override {
        return absl::StrFormat(
            "photonmapper (%u photons per pass, %s, radius %g%s)", m_photonCount,
            m_surfaceK > 0 ? absl::StrFormat("%d nearest neighbours", m_surfaceK) : "fixed radius",
            surfaceRadius(),
            m_progressive ? absl::StrFormat(", progressive, alpha %g", m_alpha) : "");
    }

  private:
    std::shared_ptr<const PhotonPassData> tracePass(const Scene& scene, uint64_t seed,
                                                    uint64_t pass) const override {
        TracedPhotons traced = tracePhotons(scene, seed, pass, m_photonCount);
        auto data = std::make_shared<PhotonPassData>();
        setSurfaceMap(*data, std::move(traced.surface), traced.emitted, pass);
        return data;
    }
};

ALPHORN_REGISTER(Integrator, "photonmapper", PhotonMapper);

}  // namespace alphorn
