// <integrator type="volume_path_mis">: volumetric path tracing with next-event estimation at
// every scattering vertex, in media and on non-delta surfaces. Shadow rays cross null boundaries
// and carry the transmittance of every medium on the way (exact for homogeneous media, ratio
// tracking for heterogeneous ones); emitter hits found by phase/BSDF sampling are weighted
// against light sampling by the balance heuristic, so direct light counts exactly once. Delta
// lights (spotlight, projector, point) are reached by light sampling only. See volume.h.
// `progressive` as in volume_path_mats.
#include "common/integrator/integrator.h"
#include "common/integrator/volume.h"

namespace alphorn {

class VolumePathMis : public Integrator {
  public:
    explicit VolumePathMis(const PropertyList& props) { props.getBoolean("progressive", false); }

    void preprocess(const Scene& scene) override { m_mediaBox = mediaBounds(scene); }

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& ray,
               const PassData*) const override {
        return volumePathLi(scene, sampler, ray, m_mediaBox, true);
    }

    std::string toString() const override { return "volume_path_mis integrator"; }

  private:
    Eigen::AlignedBox3f m_mediaBox;
};

ALPHORN_REGISTER(Integrator, "volume_path_mis", VolumePathMis);

}  // namespace alphorn
