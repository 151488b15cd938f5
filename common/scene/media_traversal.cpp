#include "common/scene/media_traversal.h"

#include "common/bsdf/bsdf.h"

namespace alphorn {

bool needsVolumetricPaths(const Scene& scene) {
    if (isParticipating(scene.camera()->medium())) return true;
    return scene.findMesh([](const Mesh& mesh) {
        return mesh.bsdf()->isNull() || isParticipating(mesh.insideMedium()) ||
               isParticipating(mesh.outsideMedium());
    }) != nullptr;
}

Eigen::AlignedBox3f mediaBounds(const Scene& scene) {
    Eigen::AlignedBox3f box = scene.bounds();
    for (const auto& emitter : scene.emitters()) {
        // Lights at infinity emit from outside the scene; media do not reach out to them.
        if (emitter->isInfinite()) continue;
        // An emitted ray starts on the light: its position for point-like lights.
        Ray3f ray;
        emitter->samplePhoton(ray, Point2f(0.5f, 0.5f), Point2f(0.5f, 0.5f));
        if (ray.o.allFinite()) box.extend(ray.o);
    }
    Ray3f cameraRay;
    const Vector2f centre = 0.5f * scene.camera()->outputSize().cast<float>();
    scene.camera()->sampleRay(cameraRay, centre, Point2f(0.5f, 0.5f));
    if (cameraRay.o.allFinite()) box.extend(cameraRay.o);
    if (box.isEmpty()) return box;
    const Vector3f margin = 0.01f * box.sizes() + Vector3f::Constant(Epsilon);
    return Eigen::AlignedBox3f(box.min() - margin, box.max() + margin);
}

void checkMediaTrackingWork(const Scene& scene) {
    const Eigen::AlignedBox3f box = mediaBounds(scene);
    const double boxDiagonal = box.isEmpty() ? 0.0 : double(box.diagonal().norm());
    auto check = [](const Medium* medium, double extent, const std::string& region) {
        if (!medium) return;
        const double collisions = double(medium->trackingMajorant()) * extent;
        if (collisions > kMaxTrackingCollisions)
            fail(
                "%s: majorant %g times %g (the diagonal of %s) is %.3g expected tracking steps "
                "per crossing, more than the limit of %.0f (2^21): lower the density, the "
                "textures' values or the declared majorant",
                medium->source(), medium->trackingMajorant(), extent, region, collisions,
                kMaxTrackingCollisions);
    };
    const std::string sceneBox = "the box around the scene that media end at";
    check(scene.camera()->medium(), boxDiagonal, sceneBox + " (the camera's medium)");
    // Only meshes that bound a medium pay for their bounds (a walk over every vertex) and the
    // messages' text: most meshes of most scenes bound none.
    for (const auto& mesh : scene.meshes()) {
        if (const Medium* inside = mesh->insideMedium()) {
            const Eigen::AlignedBox3f bounds = mesh->bounds();
            check(inside, bounds.isEmpty() ? 0.0 : double(bounds.diagonal().norm()),
                  "the bounding box of " + mesh->source() + ", which it fills");
        }
        if (const Medium* outside = mesh->outsideMedium())
            check(outside, boxDiagonal, sceneBox + " (outside " + mesh->source() + ")");
    }
    // An instanced mesh's inside medium fills the mesh's box in each placement: the largest of
    // them is the region checked.
    for (const auto& group : scene.groups()) {
        for (const auto& mesh : group->meshes()) {
            if (const Medium* inside = mesh->insideMedium()) {
                const Eigen::AlignedBox3f objectBounds = mesh->bounds();
                double diagonal = 0.0;
                for (const Instance& instance : scene.instances()) {
                    if (&instance.group() != group.get()) continue;
                    const Eigen::AlignedBox3f bounds = instance.boxToWorld(objectBounds);
                    if (!bounds.isEmpty())
                        diagonal = std::max(diagonal, double(bounds.diagonal().norm()));
                }
                check(inside, diagonal,
                      "the bounding box of " + mesh->source() + " in object \"" + group->name() +
                          "\" (its largest placement), which it fills");
            }
            if (const Medium* outside = mesh->outsideMedium())
                check(outside, boxDiagonal, sceneBox + " (outside " + mesh->source() + ")");
        }
    }
}

const Medium* mediumAt(const Scene& scene, const Point3f& p) {
    // An oblique direction, so that the ray does not run along the faces of axis-aligned boxes.
    Ray3f ray(p, Vector3f(0.5376f, 0.6132f, 0.5787f).normalized(), 0.0f, Infinity);
    for (;;) {
        Intersection its;
        if (!scene.rayIntersect(ray, its)) return nullptr;
        if (its.mesh->hasMediumInterface()) return its.mesh->mediumTowards(its, -ray.d, nullptr);
        ray = Ray3f(its.p, ray.d, Epsilon, Infinity);
    }
}

Color3f transmittanceAlong(const Scene& scene, Sampler& sampler, Ray3f ray, const Medium* medium,
                           const Eigen::AlignedBox3f& bounds) {
    Color3f result(1.0f);
    for (;;) {
        Intersection its;
        const bool hit = scene.rayIntersect(ray, its);
        if (isParticipating(medium)) {
            const float end = hit ? its.t : std::min(ray.maxt, exitDistance(bounds, ray));
            result *= medium->transmittance(Ray3f(ray.o, ray.d), end, sampler);
            if (result.isBlack()) return result;
        }
        if (!hit) return result;
        if (!its.mesh->bsdf()->isNull()) return Color3f(0.0f);
        medium = its.mesh->mediumTowards(its, ray.d, medium);
        ray = Ray3f(its.p, ray.d, Epsilon, ray.maxt - its.t);
    }
}

}  // namespace alphorn
