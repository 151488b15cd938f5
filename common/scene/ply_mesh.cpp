// <mesh type="ply">: a PLY file (ASCII or binary, optionally gzip-compressed; see
// common/scene/ply_reader.h for what is read), placed by `toWorld` as <mesh type="obj"> places
// its file. Without normals in the file, shading uses the flat triangle normal.
#include "common/core/transform.h"
#include "common/scene/ply_reader.h"
#include "common/scene/triangle_mesh.h"

#include <cerrno>
#include <cstring>
#include <fstream>

namespace alphorn {

class PlyMesh : public Mesh {
  public:
    explicit PlyMesh(const PropertyList& props) {
        const std::string filename = props.getString("filename");
        const std::string path = props.resolvePath(filename);
        const Transform toWorld = props.getTransform("toWorld", Transform());
        m_name = filename;
        TriangleGeometry geometry;
        try {
            geometry = readPlyFile(path, "PLY file " + filename);
            transformGeometry(geometry, toWorld);
            checkGeometry(geometry, "PLY file " + filename + " (after toWorld)");
        } catch (const Error& e) {
            props.fail("%s", e.what());
        }
        setGeometry(std::move(geometry.positions), std::move(geometry.normals),
                    std::move(geometry.uvs), std::move(geometry.faces));
    }
};

ALPHORN_REGISTER(Mesh, "ply", PlyMesh);

// The file a <mesh type="ply"> reads, for listing a scene's files: opened, not read.
void listPlyFile(const PropertyList& props) {
    const std::string filename = props.getString("filename");
    const std::string path = props.resolvePath(filename);
    std::ifstream file(path, std::ios::binary);
    if (!file) props.fail("cannot open PLY file \"%s\": %s", filename, std::strerror(errno));
}
ALPHORN_REGISTER_FILES(Mesh, "ply", listPlyFile);

}  // namespace alphorn
