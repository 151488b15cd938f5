// <integrator type="volume_path_mats">: volumetric path tracing by phase-function and BSDF
// sampling only: light is found only where a path hits an emitter, so
// delta lights (point, spotlight, projector) stay dark — use volume_path_mis for them. Media
// are sampled by free-flight distance (closed form when homogeneous, delta tracking otherwise);
// see volume.h for the loop and media_traversal.h for the medium bookkeeping.
//
// `progressive` (boolean, which scenes written for a progressive renderer set): its live preview
// maps onto our passes — every render is a sum of one-sample passes already — so it is accepted and
// changes nothing. A scene without media or null surfaces is rendered by path_mats's own loop (see
// needsVolumetricPaths in media_traversal.h).
#include "common/integrator/integrator.h"
#include "common/integrator/path.h"
#include "common/integrator/volume.h"

namespace alphorn {

class VolumePathMats : public Integrator {
  public:
    explicit VolumePathMats(const PropertyList& props) { props.getBoolean("progressive", false); }

    void preprocess(const Scene& scene) override {
        m_mediaBox = mediaBounds(scene);
        m_volumetric = needsVolumetricPaths(scene);
    }

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& ray,
               const PassData*) const override {
        if (!m_volumetric) return tracePath(scene, sampler, ray, -1, DirectLight::BSDFSampling);
        return volumePathLi(scene, sampler, ray, m_mediaBox, false);
    }

    std::string toString() const override { return "volume_path_mats integrator"; }

  private:
    Eigen::AlignedBox3f m_mediaBox;
    bool m_volumetric = true;
};

ALPHORN_REGISTER(Integrator, "volume_path_mats", VolumePathMats);

}  // namespace alphorn
