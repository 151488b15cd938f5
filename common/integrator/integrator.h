// Integrators estimate the radiance arriving along a camera ray. A render is a sum of passes;
// integrators that share work among all pixels of a pass (photon maps) build it in
// preparePass(), which every tile of that pass then reads.
#pragma once

#include "common/core/color.h"
#include "common/core/object.h"
#include "common/core/ray.h"

#include <optional>

namespace alphorn {

class Scene;
class Sampler;
class FilmBlock;

// Per-pass state shared by all tiles of one pass (e.g. that pass's photon maps and radius).
struct PassData {
    virtual ~PassData() = default;
};

// A progressive photon mapper's shrinking gather radius: pass i (0-based) gathers within
// progressiveRadius(initialRadius, alpha, i) of common/photon/radius_schedule.h.
struct RadiusSchedule {
    double initialRadius = 0.0;
    double alpha = 0.0;
};

class Integrator : public Object {
  public:
    ObjectKind kind() const override { return ObjectKind::Integrator; }

    // Once per scene, after loading.
    virtual void preprocess(const Scene&) {}
    // Once per pass; the result must be a pure function of (scene, seed, pass).
    virtual std::shared_ptr<const PassData> preparePass(const Scene&, uint64_t /*seed*/,
                                                        uint64_t /*pass*/) const {
        return nullptr;
    }
    // The radius schedule of an integrator whose gather radius shrinks pass by pass, valid after
    // preprocess(); progress reports show the current radius. Empty for every other integrator.
    virtual std::optional<RadiusSchedule> radiusSchedule() const { return std::nullopt; }
    // Radiance along `ray`; `pass` is what preparePass returned for the current pass.
    virtual Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& ray,
                       const PassData* pass) const = 0;
    // Contributions of a pass that land anywhere on the image rather than at the unit's own
    // camera samples (light paths connected to the camera). A unit adds those that fall on the
    // pixels [x0, x1) x [y0, y1) of its own tile, and only those, so every such contribution is
    // added exactly once whatever the tiling. `out` holds at least those pixels.
    virtual void addPassSplats(const PassData* /*pass*/, int /*x0*/, int /*y0*/, int /*x1*/,
                               int /*y1*/, FilmBlock& /*out*/) const {}
    // Whether addPassSplats() adds anything: then Li() alone is not the integrator's estimate,
    // and whatever samples Li() by itself (the t-test's scene mode) must refuse it.
    virtual bool hasPassSplats() const { return false; }
};

}  // namespace alphorn
