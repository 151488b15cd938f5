// <integrator type="bdpt">: bidirectional path tracing with MIS (balance heuristic) over all
// connection strategies: camera paths hitting emitters, next-event estimation, connections of
// inner vertices and light tracing to the camera. Parameters and the pass model are those of
// vcm_path.h; docs/scene-format.md lists them.
#include "common/integrator/vcm_path.h"

namespace alphorn {

class Bdpt : public BidirectionalIntegrator {
  public:
    explicit Bdpt(const PropertyList& props) : BidirectionalIntegrator(props, Kind::Bdpt) {}
};

ALPHORN_REGISTER(Integrator, "bdpt", Bdpt);

}  // namespace alphorn
