// <mesh type="obj">: a Wavefront OBJ file (Nori's WavefrontOBJ). Polygons are triangulated;
// a vertex is unique per (position, uv, normal) triple; missing normals give flat shading.
#include "common/core/transform.h"
#include "common/scene/mesh.h"

#include <tiny_obj_loader.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>

namespace alphorn {

// tinyobjloader's "vw" extension (skin weights) converts joint ids from float to int unchecked,
// which is undefined behaviour for ids beyond the int range. Alphorn has no use for skin
// weights, so those lines are emptied before parsing (their line breaks stay, so tinyobjloader's
// line numbers still match the file). Lines end at \n, \r or \r\n, as tinyobjloader reads them.
std::string withoutSkinWeightLines(std::string text) {
    size_t lineStart = 0;
    while (lineStart < text.size()) {
        size_t lineEnd = text.find_first_of("\r\n", lineStart);
        if (lineEnd == std::string::npos) lineEnd = text.size();
        const size_t token = text.find_first_not_of(" \t", lineStart);
        if (token < lineEnd && lineEnd - token > 2 && text[token] == 'v' &&
            text[token + 1] == 'w' && (text[token + 2] == ' ' || text[token + 2] == '\t')) {
            text.erase(lineStart, lineEnd - lineStart);
            lineEnd = lineStart;
        }
        lineStart = lineEnd + 1;
    }
    return text;
}

// Embree refuses (asserts on) rays whose origin has a coordinate beyond about 1.8e18, and rays
// leave from surface points; this bound keeps every point on a mesh far inside that range.
constexpr float kMaxVertexCoordinate = 1e15f;

class WavefrontOBJ : public Mesh {
  public:
    explicit WavefrontOBJ(const PropertyList& props) {
        std::string filename = props.getString("filename");
        std::string path = props.resolvePath(filename);
        Transform toWorld = props.getTransform("toWorld", Transform());
        m_name = filename;
        load(props, path, toWorld);
    }

  private:
    void load(const PropertyList& props, const std::string& path, const Transform& toWorld) {
        std::ifstream file(path, std::ios::binary);
        if (!file) props.fail("cannot open OBJ file \"%s\": %s", path, std::strerror(errno));
        std::stringstream contents;
        contents << file.rdbuf();
        std::istringstream stream(withoutSkinWeightLines(std::move(contents).str()));

        tinyobj::attrib_t attrib;
        std::vector<tinyobj::shape_t> shapes;
        std::vector<tinyobj::material_t> materials;
        std::string warn, err;
        // Materials are ignored (BSDFs come from the scene file), so no material reader.
        bool ok = tinyobj::LoadObj(&attrib, &shapes, &materials, &warn, &err, &stream, nullptr,
                                   /*triangulate=*/true);
        if (!ok || !err.empty()) props.fail("cannot parse OBJ file \"%s\": %s", path, err);

        std::map<std::tuple<int, int, int>, uint32_t> vertexIds;
        std::vector<std::array<int, 3>> keys;
        std::vector<uint32_t> faceIndices;
        const int positionCount = static_cast<int>(attrib.vertices.size() / 3);
        const int normalCount = static_cast<int>(attrib.normals.size() / 3);
        const int uvCount = static_cast<int>(attrib.texcoords.size() / 2);
        bool allNormals = true, allUvs = true;
        for (const auto& shape : shapes) {
            for (const auto& index : shape.mesh.indices) {
                if (index.vertex_index < 0 || index.vertex_index >= positionCount ||
                    index.normal_index >= normalCount || index.texcoord_index >= uvCount)
                    props.fail("OBJ file \"%s\" has a face with an out-of-range index", path);
                auto key =
                    std::make_tuple(index.vertex_index, index.normal_index, index.texcoord_index);
                auto [it, inserted] =
                    vertexIds.emplace(key, static_cast<uint32_t>(vertexIds.size()));
                if (inserted) {
                    keys.push_back({index.vertex_index, index.normal_index, index.texcoord_index});
                    allNormals &= index.normal_index >= 0;
                    allUvs &= index.texcoord_index >= 0;
                }
                faceIndices.push_back(it->second);
            }
        }
        if (faceIndices.empty()) props.fail("OBJ file \"%s\" contains no faces", path);

        const size_t n = keys.size();
        Eigen::Matrix<float, 3, Eigen::Dynamic> positions(3, n);
        Eigen::Matrix<float, 3, Eigen::Dynamic> normals(3, allNormals ? n : 0);
        Eigen::Matrix<float, 2, Eigen::Dynamic> uvs(2, allUvs ? n : 0);
        for (size_t i = 0; i < n; ++i) {
            const auto& [p, nIdx, t] = keys[i];
            Point3f position(attrib.vertices[3 * p], attrib.vertices[3 * p + 1],
                             attrib.vertices[3 * p + 2]);
            positions.col(i) = toWorld.applyPoint(position);
            if (!positions.col(i).allFinite())
                props.fail("OBJ file \"%s\" has a non-finite vertex position", path);
            if (positions.col(i).cwiseAbs().maxCoeff() > kMaxVertexCoordinate)
                props.fail(
                    "OBJ file \"%s\" has a vertex at (%g, %g, %g), farther out than %g (after "
                    "toWorld), where rays cannot be traced",
                    path, positions(0, i), positions(1, i), positions(2, i), kMaxVertexCoordinate);
            if (allNormals) {
                Normal3f normal(attrib.normals[3 * nIdx], attrib.normals[3 * nIdx + 1],
                                attrib.normals[3 * nIdx + 2]);
                Normal3f world = toWorld.applyNormal(normal);
                float length = world.norm();
                // A zero normal in the file falls back to the geometric normal at shading time.
                normals.col(i) = length > 0.0f ? Normal3f(world / length) : Normal3f::Zero();
            }
            if (allUvs) uvs.col(i) = Point2f(attrib.texcoords[2 * t], attrib.texcoords[2 * t + 1]);
        }
        Eigen::Matrix<uint32_t, 3, Eigen::Dynamic> faces(3, faceIndices.size() / 3);
        std::copy(faceIndices.begin(), faceIndices.end(), faces.data());
        setGeometry(std::move(positions), std::move(normals), std::move(uvs), std::move(faces));
    }
};

ALPHORN_REGISTER(Mesh, "obj", WavefrontOBJ);

}  // namespace alphorn
