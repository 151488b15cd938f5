// What loading one scene file shares among the objects it builds. The parser makes it and
// plugins reach it through their PropertyList: the mesh of an OBJ file that several <mesh>
// elements name is read and parsed once for all of them (a scene may place one mesh thousands
// of times), and dropped once the last of them has it.
#pragma once

#include "common/core/common.h"
#include "common/scene/mesh.h"

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>

namespace alphorn {

// An OBJ file's mesh before its toWorld: what each <mesh> naming the file transforms.
struct ObjGeometry {
    Eigen::Matrix<float, 3, Eigen::Dynamic> positions;
    Eigen::Matrix<float, 3, Eigen::Dynamic> normals;  // empty when the file has none
    Eigen::Matrix<float, 2, Eigen::Dynamic> uvs;      // empty when the file has none
    Eigen::Matrix<uint32_t, 3, Eigen::Dynamic> faces;
};

class SceneLoadContext {
  public:
    // Whether the scene builds its acceleration structure (SceneUse::Render) or is loaded to be
    // checked only (SceneUse::Check).
    bool buildsAcceleration() const { return m_buildsAcceleration; }
    void setBuildsAcceleration(bool builds) { m_buildsAcceleration = builds; }

    // The OBJ texts kept from the parser's count for the meshes take at most this much at once:
    // a scene naming thousands of OBJ files does not hold all their text until its meshes are
    // built. The files beyond it are read and checked again when their mesh is built.
    static constexpr uint64_t kDefaultMaxKeptObjTextBytes = uint64_t(256) << 20;

    explicit SceneLoadContext(uint64_t maxKeptObjTextBytes = kDefaultMaxKeptObjTextBytes)
        : m_maxKeptObjTextBytes(maxKeptObjTextBytes) {}

    // Before any object is built, the parser announces each <mesh type="obj"> naming the OBJ
    // file at `path` (resolved).
    void announceObjFile(const std::string& path) { ++m_objFiles[path].usesLeft; }

    // The text of the announced OBJ file at `path` as the parser's count read and prepared it
    // (countedAndPreparedObjFile), kept for the first <mesh> naming the file, which builds from
    // it instead of reading and checking the file again. It is kept while the kept texts take at
    // most the maximum together, or when it is the only one (a scene of one large OBJ file still
    // reads it once); it is dropped as that mesh takes it. Returns whether it was kept.
    bool keepObjText(const std::string& path, ObjText text) {
        auto it = m_objFiles.find(path);
        if (it == m_objFiles.end() || it->second.geometry || it->second.text) return false;
        const uint64_t bytes = text.text.size();
        if (m_keptObjTextBytes > 0 && m_keptObjTextBytes + bytes > m_maxKeptObjTextBytes)
            return false;
        m_keptObjTextBytes += bytes;
        it->second.text = std::move(text);
        return true;
    }

    // The mesh of the OBJ file at `path`, made by `build` when no earlier <mesh> left it here:
    // `build` is given the file's kept text, if any (it reads the file otherwise). The mesh
    // stays while announced <mesh> elements that have not asked for it yet name the file.
    std::shared_ptr<const ObjGeometry> objGeometry(
        const std::string& path, const std::function<ObjGeometry(std::optional<ObjText>)>& build) {
        auto it = m_objFiles.find(path);
        if (it == m_objFiles.end()) return std::make_shared<const ObjGeometry>(build(std::nullopt));
        ObjFile& file = it->second;
        std::shared_ptr<const ObjGeometry> geometry = file.geometry;
        if (!geometry) {
            std::optional<ObjText> text = std::move(file.text);
            file.text.reset();
            if (text) m_keptObjTextBytes -= text->text.size();
            geometry = std::make_shared<const ObjGeometry>(build(std::move(text)));
        }
        if (--file.usesLeft > 0)
            file.geometry = geometry;
        else
            m_objFiles.erase(it);
        return geometry;
    }

    // The bytes of OBJ text kept for meshes not built yet.
    uint64_t keptObjTextBytes() const { return m_keptObjTextBytes; }

  private:
    struct ObjFile {
        int usesLeft = 0;
        std::optional<ObjText> text;  // kept from the count until the first mesh is built
        std::shared_ptr<const ObjGeometry> geometry;
    };
    std::map<std::string, ObjFile> m_objFiles;
    bool m_buildsAcceleration = true;
    uint64_t m_maxKeptObjTextBytes;
    uint64_t m_keptObjTextBytes = 0;
};

}  // namespace alphorn
