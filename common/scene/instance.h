// Object instancing (pbrt's ObjectBegin / ObjectInstance): a group of meshes defined once in its
// own (object) space and placed in the scene any number of times, each placement a transform.
// The group's triangles and its Embree BVH exist once, however many instances place it: an
// instance costs a record here and an instance geometry in the scene's top-level BVH.
//
// A hit on an instanced mesh is reported in world space like any other (Intersection::p, t,
// shFrame, geometricNormal()): its triangle's corners are taken to world space as a mesh loaded
// with the instance's transform has them, and interpolated as that mesh would interpolate them.
// An instance therefore renders as its triangles placed flat would; under a transform that is
// exact in float (a translation by small dyadic amounts of a mesh of dyadic coordinates, with
// every ray origin a translation moves exactly), it renders the same bytes.
#pragma once

#include "common/core/transform.h"
#include "common/scene/mesh.h"

namespace alphorn {

// Meshes in their own (object) space, defined once and placed by instances. Its Embree scene is
// built once for every scene that places it (by Accel::build), however many instances do.
class MeshGroup {
  public:
    explicit MeshGroup(std::string name);
    MeshGroup(const MeshGroup&) = delete;
    MeshGroup& operator=(const MeshGroup&) = delete;

    // Adds an activated mesh (it has its BSDF), in object space. Refuses, with an Error naming
    // the mesh's source and the group: a mesh carrying an area emitter (a light is one object
    // of the scene, with one surface to sample; pbrt-v4 refuses area lights in instances too), a
    // mesh not yet activated, and any mesh once the group has been placed (its bounds and BVH
    // are then fixed).
    void addMesh(std::shared_ptr<Mesh> mesh);
    const std::vector<std::shared_ptr<Mesh>>& meshes() const { return m_meshes; }
    const std::string& name() const { return m_name; }
    // The object-space box around the meshes' vertices (empty without triangles).
    const Eigen::AlignedBox3f& bounds() const { return m_bounds; }
    size_t triangleCount() const { return m_triangles; }

    // Called when an instance places the group: no mesh may be added after.
    void markPlaced() { m_placed = true; }

  private:
    std::string m_name;
    std::vector<std::shared_ptr<Mesh>> m_meshes;
    Eigen::AlignedBox3f m_bounds;
    size_t m_triangles = 0;
    bool m_placed = false;
};

// One placement of a group: its transform from object to world space, and what a hit needs of
// it. Intersection::instance points to it.
class Instance {
  public:
    // Refuses, with an Error naming the group: no group; a transform that is not finite, not
    // affine (Embree places instances by a 3x4 matrix), or singular; and a placement that takes
    // the group's vertices farther out than kMaxInstanceCoordinate.
    Instance(std::shared_ptr<MeshGroup> group, const Transform& toWorld);

    const MeshGroup& group() const { return *m_group; }
    const std::shared_ptr<MeshGroup>& groupShared() const { return m_group; }
    const Transform& toWorld() const { return m_toWorld; }

    // A vertex in world space: Transform::applyPoint, as a mesh loaded with this transform has it.
    Point3f pointToWorld(const Point3f& p) const { return m_toWorld.applyPoint(p); }
    // A vertex normal in world space, unit length (zero stays zero): transformed by the inverse
    // transpose and normalised as a mesh loaded with this transform has it. Under a translation
    // alone it is `n` itself: a loader gave the object-space normal that normalisation already,
    // and normalising it again could move its last bit.
    Normal3f unitNormalToWorld(const Normal3f& n) const;
    // Whether the transform is a translation alone (its linear part exactly the identity).
    bool translatesOnly() const { return m_translatesOnly; }
    // The world box around the object-space box `box` (its eight corners placed).
    Eigen::AlignedBox3f boxToWorld(const Eigen::AlignedBox3f& box) const;
    // The world box around the group.
    Eigen::AlignedBox3f worldBounds() const { return boxToWorld(m_group->bounds()); }

  private:
    std::shared_ptr<MeshGroup> m_group;
    Transform m_toWorld;
    bool m_translatesOnly = false;
};

// The memory one more instance takes once the scene is built (its Instance here, Embree's instance
// geometry and its share of the top-level BVH): bench_instancing_memory measured 617 to 651 bytes
// resident per instance at 1,000 to 100,000 placements (bench/RESULTS.md); with some margin. For
// a front end that checks a scene's memory against a limit before building it.
inline constexpr uint64_t kInstanceMemoryBytes = 768;

// The farthest a placed group's vertex may lie from the origin along any axis: Embree aborts on
// ray origins beyond about 1.8e18, and rays leave from surface points (the OBJ loader keeps its
// vertices within the same bound).
inline constexpr float kMaxInstanceCoordinate = 1e15f;

}  // namespace alphorn
