// <integrator type="vcm">: vertex connection and merging. The connection strategies of bdpt and
// vertex merging (a photon density estimate at each camera vertex, over the light vertices of
// all light paths of the pass) combined by MIS; the merge radius shrinks pass by pass on the
// schedule of common/photon/radius_schedule.h. `connections` and `merging` turn either family
// off (merging only is progressive photon mapping with MIS against emitter hits), and
// `lightTracingOnly` keeps light tracing alone. Parameters: docs/scene-format.md.
#include "common/integrator/vcm_path.h"

namespace alphorn {

class Vcm : public BidirectionalIntegrator {
  public:
    explicit Vcm(const PropertyList& props) : BidirectionalIntegrator(props, Kind::Vcm) {}
};

ALPHORN_REGISTER(Integrator, "vcm", Vcm);

}  // namespace alphorn
