#include "common/scene/triangle_mesh.h"

#include "common/core/error.h"

#include <absl/strings/str_format.h>

#include <cmath>

namespace alphorn {

void transformGeometry(TriangleGeometry& geometry, const Transform& toWorld) {
    const Eigen::Index n = geometry.positions.cols();
    for (Eigen::Index i = 0; i < n; ++i)
        geometry.positions.col(i) = toWorld.applyPoint(Point3f(geometry.positions.col(i)));
    for (Eigen::Index i = 0; i < geometry.normals.cols(); ++i) {
        Normal3f world = toWorld.applyNormal(Normal3f(geometry.normals.col(i)));
        float length = world.norm();
        // Under a tiny or huge scale the transformed normal's squared length leaves the float
        // range (1e20^2 under a scale of 1e-20) though the normal is fine: scaled by its largest
        // component first, it normalises. Other normals keep the bytes the OBJ loader gives them.
        if (!std::isnormal(length) && world.allFinite() && !world.isZero()) {
            world /= world.cwiseAbs().maxCoeff();
            length = world.norm();
        }
        geometry.normals.col(i) = length > 0.0f ? Normal3f(world / length) : Normal3f::Zero();
    }
}

void flipWinding(TriangleGeometry& geometry) {
    geometry.faces.row(1).swap(geometry.faces.row(2));
}

void checkGeometry(const TriangleGeometry& geometry, const std::string& source) {
    const Eigen::Index vertices = geometry.positions.cols();
    if (geometry.faces.cols() == 0) fail("%s: the mesh has no triangles", source);
    if (geometry.normals.cols() != 0 && geometry.normals.cols() != vertices)
        fail("%s: the mesh has %d normals for %d vertices (it needs one per vertex, or none)",
             source, geometry.normals.cols(), vertices);
    if (geometry.uvs.cols() != 0 && geometry.uvs.cols() != vertices)
        fail("%s: the mesh has %d uvs for %d vertices (it needs one per vertex, or none)", source,
             geometry.uvs.cols(), vertices);
    for (Eigen::Index i = 0; i < vertices; ++i) {
        const auto p = geometry.positions.col(i);
        if (!p.allFinite())
            fail("%s: vertex %d has a position that is not finite (%g, %g, %g)", source, i, p.x(),
                 p.y(), p.z());
        if (p.cwiseAbs().maxCoeff() > kMaxMeshCoordinate)
            fail(
                "%s: vertex %d lies at (%g, %g, %g), farther out than %g, where rays cannot be "
                "traced",
                source, i, p.x(), p.y(), p.z(), kMaxMeshCoordinate);
    }
    for (Eigen::Index i = 0; i < geometry.normals.cols(); ++i)
        if (!geometry.normals.col(i).allFinite())
            fail("%s: vertex %d has a normal that is not finite", source, i);
    for (Eigen::Index i = 0; i < geometry.uvs.cols(); ++i)
        if (!geometry.uvs.col(i).allFinite())
            fail("%s: vertex %d has a uv that is not finite", source, i);
    for (Eigen::Index f = 0; f < geometry.faces.cols(); ++f)
        for (int k = 0; k < 3; ++k)
            if (geometry.faces(k, f) >= uint64_t(vertices))
                fail("%s: triangle %d uses vertex %u, but the mesh has %d vertices", source, f,
                     geometry.faces(k, f), vertices);
}

TriangleMesh::TriangleMesh(TriangleGeometry geometry, std::string source, std::string name) {
    checkGeometry(geometry, source);
    setSource(std::move(source));
    m_name = std::move(name);
    setGeometry(std::move(geometry.positions), std::move(geometry.normals), std::move(geometry.uvs),
                std::move(geometry.faces));
}

}  // namespace alphorn
