#include "common/integrator/photon_mapping.h"

#include "common/core/system_memory.h"
#include "common/integrator/direct.h"
#include "common/photon/density_estimate.h"
#include "common/photon/radius_schedule.h"

namespace alphorn {

PhotonMappingIntegrator::PhotonMappingIntegrator(const PropertyList& props,
                                                 const char* defaultDirectLight) {
    // Nori's default photon count; photon paths EMITTED per photon pass (see docs).
    const int count = props.getInteger("photonCount", 1000000);
    if (count <= 0)
        props.fail("\"photonCount\" (photons emitted per pass) must be positive, got %d", count);
    m_photonCount = static_cast<uint64_t>(count);
    m_surfaceRadiusGiven = props.has("surfacePhotonRadius");
    m_surfaceRadius = props.getFloat("surfacePhotonRadius", 0.0f);
    if (m_surfaceRadiusGiven && !(m_surfaceRadius > 0.0f && std::isfinite(m_surfaceRadius)))
        props.fail("\"surfacePhotonRadius\" must be positive and finite, got %g", m_surfaceRadius);
    m_surfaceK = props.getInteger("surfaceK", 0);
    if (props.has("surfaceK") && m_surfaceK < 2)
        props.fail("\"surfaceK\" must be at least 2 (the estimate divides by k - 1), got %d",
                   m_surfaceK);
    m_progressive = props.getBoolean("progressive", false);
    const float alpha = props.getFloat("alpha", 0.5f);
    if (!isValidRadiusAlpha(alpha))
        props.fail("\"alpha\" must be in (0, 1) (the fraction of photons kept per pass), got %g",
                   alpha);
    m_alpha = alpha;
    const std::string directLight = props.getString("directLight", defaultDirectLight);
    if (directLight != "photons" && directLight != "nee")
        props.fail("\"directLight\" must be \"photons\" or \"nee\", got \"%s\"", directLight);
    m_sampleDirectLight = directLight == "nee";
}

void PhotonMappingIntegrator::checkPassMemory(const PropertyList& props, const std::string& counts,
                                              uint64_t bytes, const std::string& perPath) {
    const uint64_t memory = physicalMemoryBytes();
    if (bytes > memory)
        props.failBeyondLimit(
            "%s need at least %s per photon pass (%s), more than this machine's %s of memory",
            counts, formatBytes(bytes), perPath, formatBytes(memory));
}

void PhotonMappingIntegrator::checkNeighbourCount(const PropertyList& props, const char* kName,
                                                  int k) {
    // A k larger than the photons found is allowed (the estimate then reads the whole search
    // disk), but k photons must exist to be found, and every query thread keeps k neighbours.
    const uint64_t bytes = uint64_t(std::max(k, 0)) * sizeof(Photon);
    const uint64_t memory = physicalMemoryBytes();
    if (bytes > memory)
        props.failBeyondLimit(
            "\"%s\" %d asks for more photons than fit in this machine's %s of memory (%s)", kName,
            k, formatBytes(memory), formatBytes(bytes));
}

float PhotonMappingIntegrator::sceneDiagonal(const Scene& scene) {
    return scene.bounds().isEmpty() ? 1.0f : scene.bounds().diagonal().norm();
}

void PhotonMappingIntegrator::preprocess(const Scene& scene) {
    // Nori's default radius: 1/500 of the scene's diagonal. A kNN search without a given radius
    // may reach across the whole scene.
    const float diagonal = sceneDiagonal(scene);
    if (!m_surfaceRadiusGiven) m_surfaceRadius = m_surfaceK > 0 ? diagonal : diagonal / 500.0f;
    if (!(m_surfaceRadius > 0.0f && std::isfinite(m_surfaceRadius)))
        fail("cannot derive a photon radius from the scene's bounds; give \"surfacePhotonRadius\"");
    std::lock_guard lock(m_cacheMutex);
    m_cached.reset();
}

std::shared_ptr<const PassData> PhotonMappingIntegrator::preparePass(const Scene& scene,
                                                                     uint64_t seed,
                                                                     uint64_t pass) const {
    if (m_progressive) return tracePass(scene, seed, pass);
    // One map for all passes of a seed: build it once, whoever asks first.
    std::lock_guard lock(m_cacheMutex);
    if (!m_cached || m_cachedSeed != seed || m_cachedScene != &scene) {
        m_cached.reset();  // free the old map before tracing the new one
        m_cached = tracePass(scene, seed, 0);
        m_cachedSeed = seed;
        m_cachedScene = &scene;
    }
    return m_cached;
}

std::optional<RadiusSchedule> PhotonMappingIntegrator::radiusSchedule() const {
    // Progress lines show the surface gather radius; kNN radii have no one value to show.
    if (!m_progressive || m_surfaceK > 0) return std::nullopt;
    return RadiusSchedule{m_surfaceRadius, m_alpha};
}

float PhotonMappingIntegrator::passRadius(float initialRadius, uint64_t pass) const {
    return m_progressive ? static_cast<float>(progressiveRadius(initialRadius, m_alpha, pass))
                         : initialRadius;
}

float PhotonMappingIntegrator::passRadiusScale(uint64_t pass) const {
    return m_progressive ? static_cast<float>(progressiveRadius(1.0, m_alpha, pass)) : 1.0f;
}

void PhotonMappingIntegrator::setSurfaceMap(PhotonPassData& data, Photons photons, uint64_t emitted,
                                            uint64_t pass) const {
    // kNN maps keep the search radius as given: progressive mode shrinks each query's kNN
    // radius instead (surfaceRadiusScale).
    const float radius = m_surfaceK > 0 ? m_surfaceRadius : passRadius(m_surfaceRadius, pass);
    data.surface =
        PhotonMap(std::move(photons),
                  m_surfaceK > 0 ? PhotonMap::Lookup::Nearest : PhotonMap::Lookup::Radius, radius);
    data.emitted = emitted;
    data.powerScale = emitted > 0 ? 1.0 / static_cast<double>(emitted) : 0.0;
    data.surfaceRadius = radius;
    data.surfaceRadiusScale = m_surfaceK > 0 ? passRadiusScale(pass) : 1.0f;
}

namespace {

// The k nearest photons of x within maxRadius, closest first, and the disk the estimate reads:
// with k found, the k − 1 nearer ones (the candidates) within the k-th's distance R; with fewer,
// all of them within maxRadius.
struct NearestDisk {
    const PhotonNeighbor* neighbors;
    size_t candidates;
    double radius2;
};
NearestDisk nearestDisk(const PhotonMap& map, const Point3f& x, size_t k, float maxRadius) {
    thread_local std::vector<PhotonNeighbor> neighbors;
    if (neighbors.size() < k) neighbors.resize(k);
    const size_t found = map.nearest(x, k, maxRadius, neighbors.data());
    if (found == k && neighbors[k - 1].distance2 > 0.0f)
        return {neighbors.data(), k - 1, double(neighbors[k - 1].distance2)};
    return {neighbors.data(), found, double(maxRadius) * double(maxRadius)};
}

// The k-nearest-neighbour estimate of progressive mode: with R the distance to the k-th nearest
// photon of the pass (or the search radius when fewer than k lie within it), the photons within
// s R, divided by π (s R)², where s = r_pass / r_0 is the Knaus–Zwicker factor shared with the
// fixed radii. For s = 1 it is nearestNeighbourEstimate() (density_estimate.h). Why it converges
// where averaging passes of that estimate does not: the photon mass M within R is a Beta(k,
// n − k + 1) variate (n photons) whatever the density's shape, so E[(k − 1) / M] = 1 exactly;
// given R, the k − 1 nearer photons fall inside the disk by the density, a fraction of them
// inside the inner disk of radius s R, so the estimate's expectation is the density's mean over
// the inner disk — whose blur vanishes as s shrinks, while the variance of the pass average
// falls as for fixed radii (the inner disk holds about (k − 1) s² photons, as a fixed radius r_i
// does r_i² / r_0²).
template <typename Weight>
Color3f shrunkNearestNeighbourEstimate(const PhotonMap& map, const Point3f& x, size_t k,
                                       float maxRadius, float scale, Weight&& weight) {
    const auto [neighbors, candidates, radius2] = nearestDisk(map, x, k, maxRadius);
    const Photons& photons = map.photons();
    const double scaled2 = double(scale) * double(scale) * radius2;
    Color3f sum(0.0f);
    // Closest first: the photons inside the inner disk are a prefix.
    for (size_t i = 0; i < candidates && double(neighbors[i].distance2) <= scaled2; ++i)
        sum += weight(photons[neighbors[i].index]);
    if (sum.isBlack()) return sum;
    return sum * static_cast<float>(1.0 / (M_PI * scaled2));
}

// The k-nearest-neighbour estimate of the pass (nearestNeighbourEstimate() when `scale` is 1,
// shrunkNearestNeighbourEstimate() otherwise: the same floats) and the same at the smaller scale
// scale * sqrt(kSmallerRadiusAreaRatio), from one query: the smaller inner disk's photons are a
// prefix of the larger's, and its expectation is the density's mean over a disk of the same R
// with half the area, so its blur is half the pass's, as for fixed radii.
template <typename Weight>
TwoRadiiRadiance nearestNeighbourEstimateTwoScales(const PhotonMap& map, const Point3f& x, size_t k,
                                                   float maxRadius, float scale, Weight&& weight) {
    const auto [neighbors, candidates, radius2] = nearestDisk(map, x, k, maxRadius);
    const Photons& photons = map.photons();
    // At scale 1 every candidate counts (as nearestNeighbourEstimate() counts them), whatever
    // the rounding of the search radius.
    const bool shrunk = scale != 1.0f;
    const double scaled2 = shrunk ? double(scale) * double(scale) * radius2 : radius2;
    const double smaller2 = scaled2 * kSmallerRadiusAreaRatio;
    Color3f sum(0.0f), smallerSum(0.0f);
    for (size_t i = 0; i < candidates; ++i) {
        const double distance2 = neighbors[i].distance2;
        if (shrunk && distance2 > scaled2) break;
        const Color3f w = weight(photons[neighbors[i].index]);
        sum += w;
        if (distance2 <= smaller2) smallerSum += w;
    }
    TwoRadiiRadiance result{sum, smallerSum};
    if (!sum.isBlack()) result.atPassRadius = sum * static_cast<float>(1.0 / (M_PI * scaled2));
    if (!smallerSum.isBlack())
        result.atSmallerRadius = smallerSum * static_cast<float>(1.0 / (M_PI * smaller2));
    return result;
}

}  // namespace

std::optional<Vector3f> PhotonMappingIntegrator::followDeltaChain(const Intersection& its,
                                                                  const Vector3f& wi, int depth,
                                                                  Sampler& sampler,
                                                                  Color3f& throughput,
                                                                  float& etaScale) {
    if (depth >= 3) {
        const float q = std::min(throughput.maxCoeff() * etaScale, 0.99f);
        if (!(sampler.next1D() < q)) return std::nullopt;
        throughput /= q;
    }
    BSDFQueryRecord rec = makeBSDFQuery(its, wi);
    const Color3f weight = its.mesh->bsdf()->sample(rec, sampler.next2D());
    if (weight.isBlack() || !weight.allFinite()) return std::nullopt;
    throughput *= weight;
    etaScale *= rec.eta * rec.eta;
    return its.toWorld(rec.wo);
}

Color3f PhotonMappingIntegrator::reflectedRadiance(const PhotonPassData& data,
                                                   const Intersection& its, const BSDF& bsdf,
                                                   const Vector3f& wi) const {
    if (data.surface.empty()) return Color3f(0.0f);
    BSDFQueryRecord rec = makeBSDFQuery(its, wi);
    rec.measure = Measure::SolidAngle;
    // The photon power density already holds the cosine at the surface: no cos here.
    auto weight = [&](const Photon& photon) {
        rec.wo = its.toLocal(photon.direction);
        return Color3f(bsdf.eval(rec) * photon.power);
    };
    const size_t k = static_cast<size_t>(m_surfaceK);
    Color3f density;
    if (m_surfaceK == 0)
        density = fixedRadiusEstimate(data.surface, its.p, data.surfaceRadius, weight);
    else if (data.surfaceRadiusScale == 1.0f)
        density = nearestNeighbourEstimate(data.surface, its.p, k, data.surfaceRadius, weight);
    else
        density = shrunkNearestNeighbourEstimate(data.surface, its.p, k, data.surfaceRadius,
                                                 data.surfaceRadiusScale, weight);
    return density * static_cast<float>(data.powerScale);
}

TwoRadiiRadiance PhotonMappingIntegrator::reflectedRadianceTwoRadii(const PhotonPassData& data,
                                                                    const Intersection& its,
                                                                    const BSDF& bsdf,
                                                                    const Vector3f& wi) const {
    if (data.surface.empty()) return {Color3f(0.0f), Color3f(0.0f)};
    BSDFQueryRecord rec = makeBSDFQuery(its, wi);
    rec.measure = Measure::SolidAngle;
    auto weight = [&](const Photon& photon) {
        rec.wo = its.toLocal(photon.direction);
        return Color3f(bsdf.eval(rec) * photon.power);
    };
    TwoRadiiRadiance density;
    if (m_surfaceK == 0) {
        const float smallerRadius =
            static_cast<float>(double(data.surfaceRadius) * std::sqrt(kSmallerRadiusAreaRatio));
        const auto [atPassRadius, atSmallerRadius] = fixedRadiusEstimateTwoRadii(
            data.surface, its.p, data.surfaceRadius, smallerRadius, weight);
        density = {atPassRadius, atSmallerRadius};
    } else {
        density =
            nearestNeighbourEstimateTwoScales(data.surface, its.p, static_cast<size_t>(m_surfaceK),
                                              data.surfaceRadius, data.surfaceRadiusScale, weight);
    }
    const float scale = static_cast<float>(data.powerScale);
    return {density.atPassRadius * scale, density.atSmallerRadius * scale};
}

}  // namespace alphorn
