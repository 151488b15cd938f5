// Ray intersection through Embree: one BVH over all meshes of a scene.
#pragma once

#include "common/core/ray.h"
#include "common/scene/mesh.h"

#include <embree3/rtcore.h>

namespace alphorn {

class Accel {
  public:
    Accel() = default;
    Accel(const Accel&) = delete;
    Accel& operator=(const Accel&) = delete;
    ~Accel();

    void build(const std::vector<std::shared_ptr<Mesh>>& meshes);
    bool intersect(const Ray3f& ray, Intersection& its) const;
    bool occluded(const Ray3f& ray) const;
    const Eigen::AlignedBox3f& bounds() const { return m_bounds; }
    // The Embree scene itself, for benchmarks that measure raw Embree throughput.
    RTCScene embreeScene() const { return m_scene; }

  private:
    void release();

    RTCDevice m_device = nullptr;
    RTCScene m_scene = nullptr;
    std::vector<const Mesh*> m_meshes;  // indexed by Embree geometry id
    Eigen::AlignedBox3f m_bounds;
};

// Rays traced by the calling thread since it started; summed by the renderer for Mrays/s.
uint64_t raysTracedByThisThread();

}  // namespace alphorn
