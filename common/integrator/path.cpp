#include "common/integrator/path.h"

#include "common/integrator/direct.h"

namespace alphorn {

int maxDepthProperty(const PropertyList& props) {
    const int maxDepth = props.getInteger("maxDepth", -1);
    if (maxDepth < -1) props.fail("\"maxDepth\" must be -1 (unlimited) or >= 0");
    return maxDepth;
}

Color3f tracePath(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay, int maxDepth,
                  DirectLight strategy) {
    Color3f result(0.0f), throughput(1.0f);
    float etaScale = 1.0f;
    // Density of the BSDF sample that produced `ray`; negative for the camera ray and for delta
    // bounces, whose emission hits emitter sampling cannot produce.
    float bsdfPdf = -1.0f;
    Ray3f ray = cameraRay;
    for (int depth = 0;; ++depth) {
        Intersection its;
        if (!scene.rayIntersect(ray, its)) {
            // The ray left the scene: it sees the environment, weighted as an emitter hit is.
            if (!scene.environmentEmitters().empty() &&
                !(bsdfPdf >= 0.0f && strategy == DirectLight::EmitterSampling)) {
                const float misPdf = strategy == DirectLight::MIS ? bsdfPdf : -1.0f;
                result += throughput * escapedRadiance(scene, ray.o, ray.d.normalized(), misPdf);
            }
            break;
        }
        const Vector3f dir = ray.d.normalized();
        const Color3f le = emittedRadiance(ray.o, dir, its);
        if (!le.isBlack()) {
            float w = 1.0f;
            if (bsdfPdf >= 0.0f && strategy == DirectLight::EmitterSampling)
                w = 0.0f;
            else if (bsdfPdf >= 0.0f && strategy == DirectLight::MIS)
                w = balanceHeuristic(bsdfPdf, emitterSamplingPdf(scene, ray.o, dir, its));
            result += throughput * le * w;
        }
        if (maxDepth >= 0 && depth >= maxDepth) break;

        if (depth >= 3) {
            const float q = std::min(throughput.maxCoeff() * etaScale, 0.99f);
            if (sampler.next1D() >= q) break;
            throughput /= q;
        }

        const BSDF& bsdf = *its.mesh->bsdf();
        const Vector3f wi = its.toLocal(-dir);
        // The light sample, then the bounce, then the light's contribution (directLight says
        // why); the sampler's numbers are drawn in that order, as sampleDirect() would.
        const bool direct = strategy != DirectLight::BSDFSampling && bsdf.isDiffuse();
        const LightSample light = direct ? sampleLight(scene, sampler, its.p) : LightSample(its.p);
        BSDFQueryRecord bRec = makeBSDFQuery(its, wi);
        const Color3f weight = bsdf.sample(bRec, sampler.next2D());
        if (direct)
            result +=
                throughput * directLight(scene, its, bsdf, wi, light, strategy == DirectLight::MIS);
        if (weight.isBlack() || !weight.allFinite()) break;
        // Only MIS needs the density itself; the others only ask whether the bounce was delta.
        if (bRec.measure == Measure::Discrete)
            bsdfPdf = -1.0f;
        else
            bsdfPdf = strategy == DirectLight::MIS ? bsdf.pdf(bRec) : 0.0f;
        throughput *= weight;
        etaScale *= bRec.eta * bRec.eta;
        ray = Ray3f(its.p, its.toWorld(bRec.wo));
    }
    return result;
}

}  // namespace alphorn
