// What loading one scene file shares among the objects it builds. The parser makes it and
// plugins reach it through their PropertyList: the mesh of an OBJ file that several <mesh>
// elements name is read and parsed once for all of them (a scene may place one mesh thousands
// of times), and dropped once the last of them has it.
#pragma once

#include "common/core/common.h"

#include <functional>
#include <map>
#include <memory>
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

    // Before any object is built, the parser announces each <mesh type="obj"> naming the OBJ
    // file at `path` (resolved).
    void announceObjFile(const std::string& path) { ++m_objFiles[path].usesLeft; }

    // The mesh of the OBJ file at `path`, made by `read` when no earlier <mesh> left it here:
    // it stays while announced <mesh> elements that have not asked for it yet name the file.
    std::shared_ptr<const ObjGeometry> objGeometry(const std::string& path,
                                                   const std::function<ObjGeometry()>& read) {
        auto it = m_objFiles.find(path);
        if (it == m_objFiles.end()) return std::make_shared<const ObjGeometry>(read());
        ObjFile& file = it->second;
        std::shared_ptr<const ObjGeometry> geometry =
            file.geometry ? file.geometry : std::make_shared<const ObjGeometry>(read());
        if (--file.usesLeft > 0)
            file.geometry = geometry;
        else
            m_objFiles.erase(it);
        return geometry;
    }

  private:
    struct ObjFile {
        int usesLeft = 0;
        std::shared_ptr<const ObjGeometry> geometry;
    };
    std::map<std::string, ObjFile> m_objFiles;
    bool m_buildsAcceleration = true;
};

}  // namespace alphorn
