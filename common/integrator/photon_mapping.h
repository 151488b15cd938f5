// What photonmapper and volumetric_photonmapper share: the surface photon map's parameters
// (`photonCount`, `surfacePhotonRadius`, `surfaceK`, `progressive`, `alpha`), how direct light
// reaches the first non-delta surface (`directLight`), the pass data
// (one cached map per seed, or in progressive mode each pass's own photons at its radius from
// the one shared schedule), the radius schedule for progress reports, and the surface density
// estimate. Each integrator adds only how it traces photons and how camera paths gather.
#pragma once

#include "common/integrator/integrator.h"
#include "common/integrator/photon_pass.h"
#include "common/photon/photon_tracer.h"

#include <mutex>

namespace alphorn {

class BSDF;
class Sampler;
struct Intersection;

class PhotonMappingIntegrator : public Integrator {
  public:
    // Derived classes that override it call it first: it sets the default surface radius and
    // drops the cached maps of an earlier scene.
    void preprocess(const Scene& scene) override;
    std::shared_ptr<const PassData> preparePass(const Scene& scene, uint64_t seed,
                                                uint64_t pass) const final;
    std::optional<RadiusSchedule> radiusSchedule() const override;

  protected:
    // `defaultDirectLight`: the `directLight` mode when the scene gives none ("nee" or
    // "photons").
    PhotonMappingIntegrator(const PropertyList& props, const char* defaultDirectLight);

    // Traces the photons of `pass` (pass 0 for the one map of non-progressive mode) and builds
    // its maps; must be a pure function of (scene, seed, pass).
    virtual std::shared_ptr<const PhotonPassData> tracePass(const Scene& scene, uint64_t seed,
                                                            uint64_t pass) const = 0;
    // The gather radius of `pass` for a map whose first pass uses `initialRadius`: shrunk by
    // the Knaus–Zwicker schedule in progressive mode, constant otherwise.
    float passRadius(float initialRadius, uint64_t pass) const;
    // r_pass / r_0 of that schedule (1 without `progressive`): the factor by which progressive
    // mode shrinks the radii that k nearest neighbours give (see photon_mapping.cpp).
    float passRadiusScale(uint64_t pass) const;
    // Whether the camera path's first non-delta surface samples the lights (next-event
    // estimation): then the photon tracer must skip the photons of light arriving there
    // directly, which would otherwise count twice.
    bool samplesDirectLight() const { return m_sampleDirectLight; }
    DirectPhotons directPhotons() const {
        return m_sampleDirectLight ? DirectPhotons::Skip : DirectPhotons::Store;
    }
    // Fills `data`'s surface map from `photons`, whose paths numbered `emitted`.
    void setSurfaceMap(PhotonPassData& data, Photons photons, uint64_t emitted,
                       uint64_t pass) const;
    // Radiance leaving the non-delta surface `its` towards wi (local), from the surface photons.
    Color3f reflectedRadiance(const PhotonPassData& data, const Intersection& its, const BSDF& bsdf,
                              const Vector3f& wi) const;
    // reflectedRadiance() (the same floats) and the same at the pass's smaller radius
    // (kSmallerRadiusAreaRatio of its disk), from one query: of a fixed-radius map at the
    // pass's radius, or of a kNN map at the pass's k neighbours, the smaller disk then
    // kSmallerRadiusAreaRatio of the shrunk kNN disk.
    TwoRadiiRadiance reflectedRadianceTwoRadii(const PhotonPassData& data, const Intersection& its,
                                               const BSDF& bsdf, const Vector3f& wi) const;
    // Progressive mode (fixed radii or k nearest neighbours): the camera paths can gather at two
    // radii. Without it, the passes share one map and its radius, whose bias no pass reduces.
    bool gathersAtTwoRadii() const { return m_progressive; }
    // One step of a camera path along a chain of delta surfaces (mirrors, glass) at `its`,
    // seen from local direction `wi`: Russian roulette from the fourth bounce on (`depth`
    // counts the earlier ones; roulette, not a cap, ends chains between mirrors), then the
    // BSDF sample. Updates the path's throughput and eta scale and returns the new world
    // direction (not normalised), or nothing when the path ends.
    static std::optional<Vector3f> followDeltaChain(const Intersection& its, const Vector3f& wi,
                                                    int depth, Sampler& sampler,
                                                    Color3f& throughput, float& etaScale);
    // Refuses photon counts whose pass cannot fit in this machine's memory: `bytes` is the least
    // a pass holds (one stored photon per path), `counts` names the counts and `perPath` how the
    // bytes were counted, for the message.
    static void checkPassMemory(const PropertyList& props, const std::string& counts,
                                uint64_t bytes, const std::string& perPath);
    // Refuses k nearest neighbours (`kName`, 0: off) whose k photons cannot fit in memory.
    static void checkNeighbourCount(const PropertyList& props, const char* kName, int k);
    // The surface radius as given or derived from the scene; the diagonal of its bounds (a
    // default for other radii).
    float surfaceRadius() const { return m_surfaceRadius; }
    static float sceneDiagonal(const Scene& scene);

    uint64_t m_photonCount;  // photon paths emitted per photon pass
    int m_surfaceK;          // 0: fixed radius
    bool m_progressive;
    double m_alpha;
    bool m_sampleDirectLight;  // `directLight` "nee"; false for "photons"

  private:
    float m_surfaceRadius;
    bool m_surfaceRadiusGiven;

    mutable std::mutex m_cacheMutex;
    mutable std::shared_ptr<const PhotonPassData> m_cached;
    mutable uint64_t m_cachedSeed = 0;
    mutable const Scene* m_cachedScene = nullptr;
};

}  // namespace alphorn
