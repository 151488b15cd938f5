// <integrator type="photonmapper">: surface photon mapping (Jensen), and progressive photon
// mapping with the Knaus–Zwicker radius schedule.
//
// Photons: `photonCount` photon paths are emitted per photon pass, from emitters chosen in
// proportion to their power (common/photon/photon_tracer.h), and stored at non-delta surfaces;
// their power is divided by the number emitted, never by the number stored.
// Camera paths: from the camera through any chain of delta (mirror, glass, null) surfaces to the
// first non-delta hit, where the reflected radiance is the photon density estimate, and
// emission is added wherever the path hits an emitter; at its first two delta surfaces it
// follows both lobes of glass (see follow()). Direct light is counted exactly once,
// by one of two means (`directLight`):
// - "photons": photons carry all of it, so the image is the photon estimate plus the emitters
//   seen directly or through delta surfaces;
// - "nee" (the default): the first non-delta hit samples one light (next-event estimation,
//   sampleDirect() of the path tracers, without MIS: the path ends there, so no BSDF sample
//   could find the light), and the photon tracer skips each path's photon of light that reached
//   a surface without scattering on the way. Light → mirror/glass → diffuse paths (caustics)
//   still come from photons; a null surface between light and point blocks the shadow ray and
//   counts as a scattering event for the photon, so those paths also stay with the photons.
//   Fewer photons are stored (none of direct light), which makes a pass cheaper, and the
//   direct light's edges are sampled sharply where a density estimate blurs them.
//
// Passes: without `progressive`, every pass reads one photon map, traced once per (scene, seed)
// from pass 0's photon streams, with a fixed radius or k nearest neighbours; more passes
// average camera noise only (classic photon mapping). With `progressive`, pass i traces its own
// photons (streams of pass i) and gathers at r_i from the one shared schedule
// (common/photon/radius_schedule.h); the image, the average of the passes, converges. With
// `surfaceK` too, each query's kNN radius is shrunk by the same factor r_i / r_0 (see
// photon_mapping.cpp), which converges as well.
#include "common/integrator/direct.h"
#include "common/integrator/photon_mapping.h"
#include "common/photon/photon_tracer.h"

#include <absl/strings/str_format.h>

namespace alphorn {

class PhotonMapper : public PhotonMappingIntegrator {
  public:
    // Next-event estimation by default: at equal time it measured ahead of photon-carried direct
    // light on the Cornell box and the caustic (bench/photon_direct_light.cpp, bench/RESULTS.md).
    explicit PhotonMapper(const PropertyList& props) : PhotonMappingIntegrator(props, "nee") {
        checkPassMemory(props, absl::StrFormat("\"photonCount\" %u photon paths", m_photonCount),
                        m_photonCount * sizeof(Photon),
                        absl::StrFormat("%zu bytes per path for one stored photon; paths that "
                                        "bounce store more",
                                        sizeof(Photon)));
        checkNeighbourCount(props, "surfaceK", m_surfaceK);
    }

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
               const PassData* passData) const override {
        return trace<false>(scene, sampler, cameraRay, passData).atPassRadius;
    }

    bool estimatesBiasWithTwoRadii() const override { return gathersAtTwoRadii(); }
    TwoRadiiRadiance LiTwoRadii(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
                                const PassData* passData) const override {
        if (!gathersAtTwoRadii())
            fail("photonmapper gathers at two radii only in progressive mode");
        return trace<true>(scene, sampler, cameraRay, passData);
    }

    std::string toString() const override {
        return absl::StrFormat(
            "photonmapper (%u photons per pass, %s, radius %g%s, direct light %s)", m_photonCount,
            m_surfaceK > 0 ? absl::StrFormat("%d nearest neighbours", m_surfaceK) : "fixed radius",
            surfaceRadius(),
            m_progressive ? absl::StrFormat(", progressive, alpha %g", m_alpha) : "",
            samplesDirectLight() ? "sampled" : "from photons");
    }

  private:
    // The camera path. With TwoRadii, the radiance at the smaller radius too: the same path with
    // the photon estimate gathered at the smaller radius (the first result's floats are Li()'s).
    template <bool TwoRadii>
    TwoRadiiRadiance trace(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
                           const PassData* passData) const {
        return follow<TwoRadii>(scene, sampler, photonPassData(passData), cameraRay, Color3f(1.0f),
                                1.0f, 0);
    }

    // The path from `ray` on, its radiance already multiplied by `throughput`. At the first
    // kSplitDepth delta surfaces of the path, a BSDF with several delta lobes (glass) has every
    // lobe followed, each with its weight, where sampling would pick one: a small bright light
    // seen in a glass sphere's reflection is otherwise found only by the few paths that draw the
    // reflection (4% at normal incidence), and those pixels' noise dominates the image's.
    template <bool TwoRadii>
    TwoRadiiRadiance follow(const Scene& scene, Sampler& sampler, const PhotonPassData& data,
                            Ray3f ray, Color3f throughput, float etaScale, int depth) const {
        Color3f result(0.0f), smallerResult(0.0f);
        for (;; ++depth) {
            Intersection its;
            if (!scene.rayIntersect(ray, its)) {
                // The camera path is delta up to here: the environment it sees counts fully.
                const Color3f escaped =
                    throughput * escapedRadiance(scene, ray.o, ray.d.normalized());
                result += escaped;
                if constexpr (TwoRadii) smallerResult += escaped;
                break;
            }
            const Vector3f dir = ray.d.normalized();
            const Color3f emitted = throughput * emittedRadiance(ray.o, dir, its);
            result += emitted;
            if constexpr (TwoRadii) smallerResult += emitted;
            const BSDF& bsdf = *its.mesh->bsdf();
            const Vector3f wi = its.toLocal(-dir);
            if (bsdf.isDiffuse()) {
                if constexpr (TwoRadii) {
                    const TwoRadiiRadiance reflected =
                        reflectedRadianceTwoRadii(data, its, bsdf, wi);
                    result += throughput * reflected.atPassRadius;
                    smallerResult += throughput * reflected.atSmallerRadius;
                } else {
                    result += throughput * reflectedRadiance(data, its, bsdf, wi);
                }
                if (samplesDirectLight()) {
                    const Color3f direct =
                        throughput * sampleDirect(scene, sampler, its, bsdf, wi, false);
                    result += direct;
                    if constexpr (TwoRadii) smallerResult += direct;
                }
                break;
            }
            DeltaLobe lobes[BSDF::kMaxDeltaLobes];
            const int lobeCount =
                depth < kSplitDepth ? bsdf.deltaLobes(makeBSDFQuery(its, wi), lobes) : 0;
            if (lobeCount > 0) {
                for (int i = 0; i < lobeCount; ++i) {
                    const TwoRadiiRadiance branch = follow<TwoRadii>(
                        scene, sampler, data, Ray3f(its.p, its.toWorld(lobes[i].wo)),
                        throughput * lobes[i].weight, etaScale * lobes[i].eta * lobes[i].eta,
                        depth + 1);
                    result += branch.atPassRadius;
                    if constexpr (TwoRadii) smallerResult += branch.atSmallerRadius;
                }
                break;
            }
            const auto wo = followDeltaChain(its, wi, depth, sampler, throughput, etaScale);
            if (!wo) break;
            ray = Ray3f(its.p, *wo);
        }
        return {result, smallerResult};
    }

    // Delta surfaces split on a camera path: a glass sphere's front (reflection, refraction)
    // and back; up to four branches per path. Below the Russian roulette's depth (3), so a
    // branch never carries a roulette weight.
    static constexpr int kSplitDepth = 2;

    std::shared_ptr<const PhotonPassData> tracePass(const Scene& scene, uint64_t seed,
                                                    uint64_t pass) const override {
        TracedPhotons traced = tracePhotons(scene, seed, pass, m_photonCount, directPhotons());
        auto data = std::make_shared<PhotonPassData>();
        setSurfaceMap(*data, std::move(traced.surface), traced.emitted, pass);
        return data;
    }
};

ALPHORN_REGISTER(Integrator, "photonmapper", PhotonMapper);

}  // namespace alphorn
