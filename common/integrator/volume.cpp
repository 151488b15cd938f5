#include "common/integrator/volume.h"

#include "common/emitter/delta_light.h"

#include <optional>

namespace alphorn {

namespace {

// One equiangular estimate of the light that a uniformly chosen emitter scatters into the
// segment towards its origin (nothing when the emitter chosen is not point-like), MIS-weighted
// against free-flight sampling. Always draws 1D + 1D + 2D numbers (plus what ratio tracking on
// the shadow ray needs).
Color3f sampleEquiangular(const Scene& scene, Sampler& sampler, const EquiangularSegment& segment,
                          const Medium& medium, const Color3f& sigmaS,
                          const Eigen::AlignedBox3f& bounds) {
    float selection = sampler.next1D();
    const float u = sampler.next1D();
    const Point2f lightSample = sampler.next2D();
    float selectionPdf = 0.0f;
    const auto* light =
        dynamic_cast<const DeltaPositionLight*>(scene.sampleEmitter(selection, selectionPdf));
    if (!light || !(selectionPdf > 0.0f)) return Color3f(0.0f);
    const EquiangularFrame frame = equiangularFrame(segment, light->position());
    if (!frame.valid) return Color3f(0.0f);
    const float t = std::clamp(
        frame.delta + frame.distance * std::tan(frame.thetaA + u * (frame.thetaB - frame.thetaA)),
        0.0f, segment.end);
    const float pdf = equiangularPdf(frame, t);
    if (!(pdf > 0.0f) || !std::isfinite(t)) return Color3f(0.0f);

    EmitterQueryRecord lRec(segment.origin + t * segment.direction);
    const Color3f radianceOverPdf = light->sample(lRec, lightSample);
    if (radianceOverPdf.isBlack()) return Color3f(0.0f);
    const float phase = medium.phase().eval(-segment.direction, lRec.wi);
    if (!(phase > 0.0f)) return Color3f(0.0f);
    const Color3f tr = transmittanceAlong(scene, sampler, lRec.shadowRay, &medium, bounds);
    if (tr.isBlack()) return Color3f(0.0f);
    const float weight = balanceHeuristic(pdf, freeFlightPdf(segment, t));
    return sigmaS * std::exp(-segment.sigmaT * t) * phase * tr * radianceOverPdf * weight /
           (pdf * selectionPdf);
}

}  // namespace

Color3f sampleLightThroughMedia(const Scene& scene, Sampler& sampler, const ScatteringVertex& v,
                                const Eigen::AlignedBox3f& bounds, bool mis) {
    const LightSample light = sampleLight(scene, sampler, v.p);
    if (!light.emitter) return Color3f(0.0f);
    const Emitter* emitter = light.emitter;
    const EmitterQueryRecord& lRec = light.rec;
    const Color3f& radianceOverPdf = light.radianceOverPdf;
    const float selectionPdf = light.selectionPdf;

    Color3f f;
    float scatterPdf;
    const Medium* shadowMedium = v.medium;
    if (v.its) {
        BSDFQueryRecord bRec = makeBSDFQuery(*v.its, v.its->toLocal(v.wi));
        bRec.wo = v.its->toLocal(lRec.wi);
        bRec.measure = Measure::SolidAngle;
        f = v.bsdf->eval(bRec) * std::abs(Frame::cosTheta(bRec.wo));
        scatterPdf = v.bsdf->pdf(bRec);
        shadowMedium = v.its->mesh->mediumTowards(*v.its, lRec.wi, v.medium);
    } else {
        f = Color3f(v.medium->phase().eval(v.wi, lRec.wi));
        scatterPdf = v.medium->phase().pdf(v.wi, lRec.wi);
    }
    if (f.isBlack()) return Color3f(0.0f);
    // The shadow ray is traced last: it is the expensive part and often unnecessary.
    const Color3f tr = transmittanceAlong(scene, sampler, lRec.shadowRay, shadowMedium, bounds);
    if (tr.isBlack()) return Color3f(0.0f);

    Color3f result = f * tr * radianceOverPdf / selectionPdf;
    if (mis && !emitter->isDelta()) result *= balanceHeuristic(lRec.pdf * selectionPdf, scatterPdf);
    // Equiangular sampling reaches point-like lights only (not directional ones).
    if (v.segment && dynamic_cast<const DeltaPositionLight*>(emitter))
        result *= balanceHeuristic(freeFlightPdf(*v.segment, v.t),
                                   equiangularPdf(equiangularFrame(*v.segment, lRec.p), v.t));
    return result;
}

Color3f volumePathLi(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
                     const Eigen::AlignedBox3f& mediaBox, bool mis, bool equiangular) {
    Color3f result(0.0f);
    // Throughput under spectral MIS for chromatic media (see MediumSample).
    SpectralThroughput path;
    Color3f& throughput = path.throughput;
    float etaScale = 1.0f;
    // Unit direction: media measure distances in world units.
    const float length = cameraRay.d.norm();
    if (!(length > 0.0f)) return result;
    Ray3f ray(cameraRay.o, cameraRay.d / length, cameraRay.mint * length, cameraRay.maxt * length);
    const Medium* medium = scene.camera()->medium();
    Eigen::AlignedBox3f bounds = mediaBox;
    bounds.extend(cameraRay.o);
    // Density of the phase/BSDF sample that produced the current ray, for MIS of emitter hits;
    // negative for the camera ray and after delta bounces (emission then counts fully).
    float scatterPdf = -1.0f;
    Point3f lastVertex = ray.o;  // where that sample was taken (null crossings do not move it)
    for (int depth = 0;;) {
        Intersection its;
        const bool hit = scene.rayIntersect(ray, its);
        if (isParticipating(medium)) {
            const float end = hit ? its.t : std::min(ray.maxt, exitDistance(bounds, ray));
            std::optional<EquiangularSegment> segment;
            if (equiangular) {
                const auto grey = medium->greyHomogeneous();
                if (grey && grey->sigmaT > 0.0f && !grey->sigmaS.isBlack()) {
                    segment = EquiangularSegment{ray.o, ray.d, end, grey->sigmaT};
                    result += throughput * sampleEquiangular(scene, sampler, *segment, *medium,
                                                             grey->sigmaS, bounds);
                }
            }
            const MediumSample ms =
                medium->sampleDistance(Ray3f(ray.o, ray.d), end, sampler, path.hero);
            if (ms.event == MediumSample::Event::Absorbed) break;
            path.apply(ms);
            // A purely absorbing medium "scatters" with weight sigmaS = 0: the path ends.
            if (throughput.isBlack()) break;
            if (ms.event == MediumSample::Event::Scattered) {
                if (depth >= 3) {
                    const float q = std::min(throughput.maxCoeff() * etaScale, 0.99f);
                    if (sampler.next1D() >= q) break;
                    throughput /= q;
                }
                ++depth;
                const Vector3f wi = -ray.d;
                if (mis) {
                    ScatteringVertex v;
                    v.p = ms.p;
                    v.wi = wi;
                    v.medium = medium;
                    v.segment = segment ? &*segment : nullptr;
                    v.t = ms.t;
                    result += throughput * sampleLightThroughMedia(scene, sampler, v, bounds, true);
                }
                Vector3f wo;
                const float weight = medium->phase().sample(wi, wo, sampler.next2D());
                if (!(weight > 0.0f)) break;
                throughput *= weight;
                scatterPdf = medium->phase().pdf(wi, wo);
                lastVertex = ms.p;
                // A scattering point is not on a surface: the next ray may start at 0.
                ray = Ray3f(ms.p, wo, 0.0f, Infinity);
                continue;
            }
        }
        if (!hit) {
            // The ray left the scene (and the media, whose transmittance up to the box they end
            // at the throughput carries, as the shadow rays' does): it sees the environment,
            // weighted as an emitter hit is.
            if (!scene.environmentEmitters().empty())
                result +=
                    throughput * escapedRadiance(scene, lastVertex, ray.d,
                                                 mis && scatterPdf >= 0.0f ? scatterPdf : -1.0f);
            break;
        }

        const Vector3f dir = ray.d;
        const Color3f le = emittedRadiance(lastVertex, dir, its);
        if (!le.isBlack()) {
            const float w =
                !mis || scatterPdf < 0.0f
                    ? 1.0f
                    : balanceHeuristic(scatterPdf, emitterSamplingPdf(scene, lastVertex, dir, its));
            result += throughput * le * w;
        }

        const BSDF& bsdf = *its.mesh->bsdf();
        if (bsdf.isNull()) {
            medium = its.mesh->mediumTowards(its, dir, medium);
            ray = Ray3f(its.p, dir, Epsilon, ray.maxt - its.t);
            continue;
        }

        if (depth >= 3) {
            const float q = std::min(throughput.maxCoeff() * etaScale, 0.99f);
            if (sampler.next1D() >= q) break;
            throughput /= q;
        }
        ++depth;

        const Vector3f wiLocal = its.toLocal(-dir);
        if (mis && bsdf.isDiffuse()) {
            const ScatteringVertex v = ScatteringVertex::onSurface(its, bsdf, dir, medium);
            result += throughput * sampleLightThroughMedia(scene, sampler, v, bounds, true);
        }

        BSDFQueryRecord bRec = makeBSDFQuery(its, wiLocal);
        const Color3f weight = bsdf.sample(bRec, sampler.next2D());
        if (weight.isBlack() || !weight.allFinite()) break;
        scatterPdf = bRec.measure == Measure::Discrete ? -1.0f : bsdf.pdf(bRec);
        lastVertex = its.p;
        throughput *= weight;
        etaScale *= bRec.eta * bRec.eta;
        const Vector3f wo = its.toWorld(bRec.wo).normalized();
        medium = its.mesh->mediumTowards(its, wo, medium);
        ray = Ray3f(its.p, wo);
    }
    return result;
}

}  // namespace alphorn
