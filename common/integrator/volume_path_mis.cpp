// <integrator type="volume_path_mis">: volumetric path tracing with next-event estimation at
// every scattering vertex, in media and on non-delta surfaces. Shadow rays cross null boundaries
// and carry the transmittance of every medium on the way (exact for homogeneous media, ratio
// tracking for heterogeneous ones); emitter hits found by phase/BSDF sampling are weighted
// against light sampling by the balance heuristic, so direct light counts exactly once. Delta
// lights (spotlight, projector, point) are reached by light sampling only. See volume.h.
// In grey homogeneous media, delta lights are also sampled by equiangular sampling along every
// segment (equiangular.h), MIS-weighted against the next-event estimates at free-flight scattering
// points; `equiangular` (default true) turns it off, for comparisons.
// `progressive` as in volume_path_mats. A scene without media or null surfaces is rendered by
// path_mis's own loop (see needsVolumetricPaths in media_traversal.h).
#include "common/integrator/integrator.h"
#include "common/integrator/path.h"
#include "common/integrator/volume.h"

namespace alphorn {

class VolumePathMis : public Integrator {
  public:
    explicit VolumePathMis(const PropertyList& props)
        : m_equiangularWanted(props.getBoolean("equiangular", true)) {
        props.getBoolean("progressive", false);
    }

    void preprocess(const Scene& scene) override {
        m_mediaBox = mediaBounds(scene);
        m_volumetric = needsVolumetricPaths(scene);
        // Only point-like lights gain from it; other scenes draw no extra numbers.
        m_equiangular = false;
        for (const auto& emitter : scene.emitters())
            m_equiangular |= m_equiangularWanted && emitter->isDelta() && !emitter->isInfinite();
    }

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& ray,
               const PassData*) const override {
        if (!m_volumetric) return tracePath(scene, sampler, ray, -1, DirectLight::MIS);
        return volumePathLi(scene, sampler, ray, m_mediaBox, true, m_equiangular);
    }

    std::string toString() const override { return "volume_path_mis integrator"; }

  private:
    Eigen::AlignedBox3f m_mediaBox;
    bool m_equiangularWanted, m_equiangular = false;
    bool m_volumetric = true;
};

ALPHORN_REGISTER(Integrator, "volume_path_mis", VolumePathMis);

}  // namespace alphorn
