// Surface density estimates over a photon map. Each returns Σ weight(photon) / area — the
// density of weighted photon power per unit area, before the division by the photons emitted.
// The weight is the caller's (for radiance: the BSDF towards the photon's direction times its
// power).
#pragma once

#include "common/core/common.h"
#include "common/photon/photon_map.h"

#include <utility>
#include <vector>

namespace alphorn {

// Fixed radius r: Σ_{|p − x| < r} w(p) / (π r²).
template <typename Weight>
Color3f fixedRadiusEstimate(const PhotonMap& map, const Point3f& x, float radius, Weight&& weight) {
    Color3f sum(0.0f);
    map.forEachWithin(x, radius, [&](const Photon& photon, float) { sum += weight(photon); });
    if (sum.isBlack()) return sum;
    return sum * static_cast<float>(1.0 / (M_PI * double(radius) * double(radius)));
}

// fixedRadiusEstimate at `radius` (the same floats) and at `smallerRadius` (< radius) from one
// query: the smaller disk's photons are those of the larger one nearer than smallerRadius.
template <typename Weight>
std::pair<Color3f, Color3f> fixedRadiusEstimateTwoRadii(const PhotonMap& map, const Point3f& x,
                                                        float radius, float smallerRadius,
                                                        Weight&& weight) {
    Color3f sum(0.0f), smallerSum(0.0f);
    const float smallerRadius2 = smallerRadius * smallerRadius;
    map.forEachWithin(x, radius, [&](const Photon& photon, float distance2) {
        const Color3f w = weight(photon);
        sum += w;
        if (distance2 < smallerRadius2) smallerSum += w;
    });
    const auto density = [](const Color3f& total, float r) {
        return total.isBlack()
                   ? total
                   : Color3f(total * static_cast<float>(1.0 / (M_PI * double(r) * double(r))));
    };
    return {density(sum, radius), density(smallerSum, smallerRadius)};
}

// k nearest neighbours, searched within maxRadius. With r_k the distance to the k-th nearest
// photon, Σ over the k − 1 nearer ones / (π r_k²): for uniformly spread photons π r_k² is a
// Gamma(k) (or Beta) variate and E[(k − 1)/(π r_k²)] is exactly the density, where the usual
// k/(π r_k²) overestimates it by k/(k − 1). Leaving out the k-th photon, which lies on the
// disk's edge, is what turns the count k into k − 1 for weighted photons.
// Fewer than k photons within maxRadius: Σ over those found / (π maxRadius²), the fixed-radius
// estimate at the search radius — never inflated by a tiny disk around a lone photon, and 0
// (not NaN) for an empty map. The same holds if the k-th photon sits exactly at x (r_k = 0).
template <typename Weight>
Color3f nearestNeighbourEstimate(const PhotonMap& map, const Point3f& x, size_t k, float maxRadius,
                                 Weight&& weight) {
    thread_local std::vector<PhotonNeighbor> neighbors;
    if (neighbors.size() < k) neighbors.resize(k);
    const size_t found = map.nearest(x, k, maxRadius, neighbors.data());
    const Photons& photons = map.photons();
    Color3f sum(0.0f);
    double radius2 = double(maxRadius) * double(maxRadius);
    size_t used = found;
    if (found == k && neighbors[k - 1].distance2 > 0.0f) {
        used = k - 1;
        radius2 = neighbors[k - 1].distance2;
    }
    for (size_t i = 0; i < used; ++i) sum += weight(photons[neighbors[i].index]);
    if (sum.isBlack()) return sum;
    return sum * static_cast<float>(1.0 / (M_PI * radius2));
}

}  // namespace alphorn
