#include "common/integrator/photon_mapping.h"

#include "common/integrator/direct.h"
#include "common/photon/density_estimate.h"
#include "common/photon/radius_schedule.h"

namespace alphorn {

PhotonMappingIntegrator::PhotonMappingIntegrator(const PropertyList& props) {
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
    // kNN radii adapt to each pass's photons; averaging passes of a kNN estimate does not
    // converge, so progressive mode needs a fixed radius to shrink.
    if (m_progressive && m_surfaceK > 0)
        props.fail(
            "\"progressive\" shrinks a fixed radius: use \"surfacePhotonRadius\", not "
            "\"surfaceK\"");
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
    if (!m_progressive) return std::nullopt;
    return RadiusSchedule{m_surfaceRadius, m_alpha};
}

float PhotonMappingIntegrator::passRadius(float initialRadius, uint64_t pass) const {
    return m_progressive ? static_cast<float>(progressiveRadius(initialRadius, m_alpha, pass))
                         : initialRadius;
}

void PhotonMappingIntegrator::setSurfaceMap(PhotonPassData& data, std::vector<Photon> photons,
                                            uint64_t emitted, uint64_t pass) const {
    const float radius = passRadius(m_surfaceRadius, pass);
    data.surface =
        PhotonMap(std::move(photons),
                  m_surfaceK > 0 ? PhotonMap::Lookup::Nearest : PhotonMap::Lookup::Radius, radius);
    data.emitted = emitted;
    data.powerScale = emitted > 0 ? 1.0 / static_cast<double>(emitted) : 0.0;
    data.surfaceRadius = radius;
}

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
    const Color3f density =
        m_surfaceK > 0
            ? nearestNeighbourEstimate(data.surface, its.p, static_cast<size_t>(m_surfaceK),
                                       data.surfaceRadius, weight)
            : fixedRadiusEstimate(data.surface, its.p, data.surfaceRadius, weight);
    return density * static_cast<float>(data.powerScale);
}

}  // namespace alphorn
