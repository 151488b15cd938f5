#include "common/scene/bilinear_patches.h"

#include "common/core/error.h"

namespace alphorn {

TriangleGeometry bilinearPatchesAsTriangles(
    const Eigen::Matrix<float, 3, Eigen::Dynamic>& positions, const std::vector<uint32_t>& indices,
    const Eigen::Matrix<float, 2, Eigen::Dynamic>& uvs,
    const Eigen::Matrix<float, 3, Eigen::Dynamic>& normals, const std::string& source) {
    const Eigen::Index vertexCount = positions.cols();
    if (indices.empty()) fail("%s: the bilinear mesh has no patches", source);
    if (indices.size() % 4 != 0)
        fail("%s: the bilinear mesh has %d vertex indices, which is not 4 a patch", source,
             indices.size());
    if (uvs.cols() != 0 && uvs.cols() != vertexCount)
        fail("%s: the bilinear mesh has %d uvs for %d vertices (it needs one per vertex, or none)",
             source, uvs.cols(), vertexCount);
    if (normals.cols() != 0 && normals.cols() != vertexCount)
        fail(
            "%s: the bilinear mesh has %d normals for %d vertices (it needs one per vertex, or "
            "none)",
            source, normals.cols(), vertexCount);
    for (size_t i = 0; i < indices.size(); ++i)
        if (indices[i] >= uint64_t(vertexCount))
            fail("%s: patch %d uses vertex %d, but the mesh has %d vertices", source, i / 4,
                 indices[i], vertexCount);

    // Four vertices a patch, numbered by uint32.
    if (indices.size() / 4 > (uint64_t(1) << 30))
        fail("%s: the bilinear mesh has %d patches, more than the %d supported", source,
             indices.size() / 4, uint64_t(1) << 30);
    const Eigen::Index patches = Eigen::Index(indices.size() / 4);
    TriangleGeometry geometry;
    geometry.positions.resize(3, 4 * patches);
    geometry.uvs.resize(2, 4 * patches);
    geometry.normals.resize(3, normals.cols() > 0 ? 4 * patches : 0);
    geometry.faces.resize(3, 2 * patches);
    // The corners' (u, v) in pbrt's order p00 p10 p01 p11.
    const Point2f corner[4] = {Point2f(0, 0), Point2f(1, 0), Point2f(0, 1), Point2f(1, 1)};
    for (Eigen::Index patch = 0; patch < patches; ++patch) {
        for (int k = 0; k < 4; ++k) {
            const uint32_t v = indices[size_t(4 * patch + k)];
            const Eigen::Index column = 4 * patch + k;
            geometry.positions.col(column) = positions.col(v);
            geometry.uvs.col(column) = uvs.cols() > 0 ? Point2f(uvs.col(v)) : corner[k];
            if (normals.cols() > 0) geometry.normals.col(column) = normals.col(v);
        }
        const uint32_t p00 = uint32_t(4 * patch), p10 = p00 + 1, p01 = p00 + 2, p11 = p00 + 3;
        geometry.faces.col(2 * patch) << p00, p10, p11;
        geometry.faces.col(2 * patch + 1) << p00, p11, p01;
    }
    return geometry;
}

}  // namespace alphorn
