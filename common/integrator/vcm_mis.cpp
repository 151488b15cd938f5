#include "common/integrator/vcm_mis.h"

#include <cmath>
#include <vector>

namespace alphorn {

namespace {

bool connectionPossible(const MisVertex* path, size_t k, const MisStrategies& strategies,
                        size_t s) {
    if (s == 0) return strategies.hits && strategies.emitterHittable && k >= 1;
    if (!path[s - 1].connectible || (s <= k && !path[s].connectible)) return false;
    if (s < k) return strategies.connections;
    // An emitter seen directly (k = 1) is left to the camera path where that can hit it: its
    // emission over a pixel is nearly constant, so the hit has next to no variance, and the
    // balance heuristic would add light tracing's variance, which grows with the square of the
    // pixel's value, to the brightest pixels of the image.
    if (k == 1 && strategies.hits && strategies.emitterHittable) return false;
    return strategies.lightTracing;
}

bool mergePossible(const MisVertex* path, size_t k, const MisStrategies& strategies, size_t m) {
    return strategies.merging && m >= 1 && m + 1 <= k && path[m].connectible;
}

}  // namespace

double misWeight(const MisVertex* path, size_t vertexCount, const MisStrategies& strategies,
                 MisStrategy strategy) {
    if (vertexCount < 2) return 0.0;
    const size_t k = vertexCount - 1;
    const bool merge = strategy.kind == MisStrategy::Kind::Merge;
    if (strategy.index < 0) return 0.0;
    const size_t index = static_cast<size_t>(strategy.index);
    if (merge ? !mergePossible(path, k, strategies, index)
              : (index > k || !connectionPossible(path, k, strategies, index)))
        return 0.0;

    // relative[s]: the density of connection s without the light-path count, relative to that
    // of connection `reference`. A merge at m is connection m + 1 times the camera-side density
    // of x_m and the merge factor. Walking away from the reference, each step swaps one
    // vertex's density from one side to the other; the denominators are densities with which
    // the path's vertices were actually sampled, so they are positive.
    thread_local std::vector<double> relative;
    relative.assign(k + 1, 0.0);
    const size_t reference = merge ? index + 1 : index;
    relative[reference] = 1.0;
    for (size_t s = reference; s > 0; --s)
        relative[s - 1] = relative[s] * path[s - 1].pdfFromCamera / path[s - 1].pdfFromLight;
    for (size_t s = reference; s < k; ++s)
        relative[s + 1] = relative[s] * path[s].pdfFromLight / path[s].pdfFromCamera;

    const double mergeFactor = strategies.lightPathCount * strategies.mergeArea;
    auto connectionDensity = [&](size_t s) {
        return s == k ? relative[s] * strategies.lightPathCount : relative[s];
    };
    auto mergeDensity = [&](size_t m) {
        return relative[m + 1] * path[m].pdfFromCamera * mergeFactor;
    };
    double sum = 0.0;
    for (size_t s = 0; s <= k; ++s)
        if (connectionPossible(path, k, strategies, s)) sum += connectionDensity(s);
    for (size_t m = 1; m + 1 <= k; ++m)
        if (mergePossible(path, k, strategies, m)) sum += mergeDensity(m);
    const double own = merge ? mergeDensity(index) : connectionDensity(index);
    const double weight = own / sum;
    return std::isfinite(weight) && weight >= 0.0 ? weight : 0.0;
}

}  // namespace alphorn
