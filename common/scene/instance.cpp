#include "common/scene/instance.h"

#include "common/core/error.h"

namespace alphorn {

MeshGroup::MeshGroup(std::string name) : m_name(std::move(name)) {}

void MeshGroup::addMesh(std::shared_ptr<Mesh> mesh) {
    if (!mesh) fail("object \"%s\": a mesh to instance is missing (null)", m_name);
    if (m_placed)
        fail("%s: object \"%s\" is already placed by an instance; its meshes are fixed then",
             mesh->source(), m_name);
    if (mesh->emitter())
        fail(
            "%s: object \"%s\" has a shape with an area light; area lights cannot be instanced "
            "(nor can they in pbrt-v4): give the emitting shape outside ObjectBegin/ObjectEnd",
            mesh->source(), m_name);
    if (!mesh->bsdf())
        fail("%s: a mesh of object \"%s\" was not activated (it has no BSDF)", mesh->source(),
             m_name);
    if (mesh->triangleCount() != 0) m_bounds.extend(mesh->bounds());
    m_triangles += mesh->triangleCount();
    m_meshes.push_back(std::move(mesh));
}

Instance::Instance(std::shared_ptr<MeshGroup> group, const Transform& toWorld)
    : m_group(std::move(group)), m_toWorld(toWorld) {
    if (!m_group) fail("an instance names no object (null)");
    const Matrix4f& m = toWorld.matrix();
    const std::string& name = m_group->name();
    m_translatesOnly = m.topLeftCorner<3, 3>().isIdentity(0.0f);
    if (!m.allFinite()) fail("the transform of an instance of object \"%s\" is not finite", name);
    if (m(3, 0) != 0.0f || m(3, 1) != 0.0f || m(3, 2) != 0.0f || m(3, 3) != 1.0f)
        fail(
            "the transform of an instance of object \"%s\" is projective (last row %g %g %g %g); "
            "instances take affine transforms only",
            name, m(3, 0), m(3, 1), m(3, 2), m(3, 3));
    // Embree inverts the 3x4 matrix to take rays into object space; Transform's inverse is the
    // test of the same (float where float holds it, double beyond).
    if (!(Transform::inverseOf(m).allFinite() && toWorld.inverseMatrix().allFinite()))
        fail("the transform of an instance of object \"%s\" is singular", name);
    const Eigen::AlignedBox3f box = worldBounds();
    if (!box.isEmpty() && !(box.min().cwiseAbs().maxCoeff() <= kMaxInstanceCoordinate &&
                            box.max().cwiseAbs().maxCoeff() <= kMaxInstanceCoordinate))
        fail(
            "an instance of object \"%s\" places it in the box (%g, %g, %g) - (%g, %g, %g), "
            "farther out than %g, where rays cannot be traced",
            name, box.min().x(), box.min().y(), box.min().z(), box.max().x(), box.max().y(),
            box.max().z(), kMaxInstanceCoordinate);
}

Normal3f Instance::unitNormalToWorld(const Normal3f& n) const {
    if (m_translatesOnly) return n;
    Normal3f world = m_toWorld.applyNormal(n);
    float length = world.norm();
    // Under a tiny or huge scale the squared length leaves the float range though the normal is
    // fine: scaled by its largest component first, it normalises (as the OBJ loader does it).
    if (!std::isnormal(length) && world.allFinite() && !world.isZero()) {
        world /= world.cwiseAbs().maxCoeff();
        length = world.norm();
    }
    return length > 0.0f ? Normal3f(world / length) : Normal3f::Zero();
}

Eigen::AlignedBox3f Instance::boxToWorld(const Eigen::AlignedBox3f& box) const {
    Eigen::AlignedBox3f world;
    if (box.isEmpty()) return world;
    for (int k = 0; k < 8; ++k) {
        const Point3f corner((k & 1) ? box.max().x() : box.min().x(),
                             (k & 2) ? box.max().y() : box.min().y(),
                             (k & 4) ? box.max().z() : box.min().z());
        world.extend(pointToWorld(corner));
    }
    return world;
}

}  // namespace alphorn
