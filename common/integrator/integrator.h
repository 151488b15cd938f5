// Integrators estimate the radiance arriving along a camera ray. A render is a sum of passes;
// integrators that share work among all pixels of a pass (photon maps) build it in
// preparePass(), which every tile of that pass then reads.
#pragma once

#include "common/core/color.h"
#include "common/core/error.h"
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

// The radiance along one camera ray gathered at a pass's radius r_i and at r_i / sqrt(2) (every
// gather disk, surface or beam, at half its area), from the same camera path and photons.
struct TwoRadiiRadiance {
    Color3f atPassRadius;
    Color3f atSmallerRadius;
};

// The smaller radius's share of the pass radius's disk area: r_small^2 = kSmallerRadiusAreaRatio
// r_i^2 (estimateRelativeBiasTwoRadii's areaRatio).
inline constexpr double kSmallerRadiusAreaRatio = 0.5;

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
    // Whether LiTwoRadii() returns the radiance at a second, smaller gather radius: a progressive
    // photon mapper (fixed or kNN radii). Its films then keep that image's sums, whose
    // difference from the image estimates the radius's bias (docs/error-estimate.md).
    virtual bool estimatesBiasWithTwoRadii() const { return false; }
    // Li() (the same floats) and, from the same gather, the radiance at the smaller radius.
    // Only for integrators whose estimatesBiasWithTwoRadii() holds.
    virtual TwoRadiiRadiance LiTwoRadii(const Scene&, Sampler&, const Ray3f&,
                                        const PassData*) const {
        fail("this integrator gathers at one radius only");
    }
    // Contributions of a pass that land anywhere on the image rather than at the unit's own
    // camera samples (light paths connected to the camera). A unit adds those that fall on the
    // pixels [x0, x1) x [y0, y1) of its own tile, and only those, so every such contribution is
    // added exactly once whatever the tiling. `out` holds at least those pixels. When `out`
    // keeps the smaller radius's image, they are added to its sums as well.
    virtual void addPassSplats(const PassData* /*pass*/, int /*x0*/, int /*y0*/, int /*x1*/,
                               int /*y1*/, FilmBlock& /*out*/) const {}
    // Whether addPassSplats() adds anything: then Li() alone is not the integrator's estimate,
    // and whatever samples Li() by itself (the t-test's scene mode) must refuse it.
    virtual bool hasPassSplats() const { return false; }
};

}  // namespace alphorn
