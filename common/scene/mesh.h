// Triangle meshes (Nori's Mesh): vertex positions, optional normals and uvs, a BSDF, and an
// optional area emitter.
#pragma once

#include "common/core/dpdf.h"
#include "common/core/frame.h"
#include "common/core/object.h"

namespace alphorn {

class BSDF;
class Emitter;
class Instance;
class Medium;
class Mesh;

// A ray-surface hit, in world space (a hit on an instanced mesh too).
struct Intersection {
    Point3f p = Point3f::Zero();
    float t = Infinity;
    Point2f uv = Point2f::Zero();
    Frame shFrame;  // shading frame (interpolated normal)
    const Mesh* mesh = nullptr;
    uint32_t triangle = 0;
    // The instance that placed `mesh` (common/scene/instance.h), whose vertices are in object
    // space; null for a mesh of the scene itself. Everything above is in world space either way:
    // read the mesh's own arrays only through the functions that take the instance.
    const Instance* instance = nullptr;

    Vector3f toLocal(const Vector3f& d) const { return shFrame.toLocal(d); }
    Vector3f toWorld(const Vector3f& d) const { return shFrame.toWorld(d); }
    // The true triangle normal, unit length. Computed on demand: most hits never ask for it,
    // and its normalisation costs three divisions.
    Normal3f geometricNormal() const;
};

// A point sampled uniformly on a mesh's surface.
struct SurfaceSample {
    Point3f p;
    Normal3f n;
    Point2f uv;
    float pdf;  // area density (1 / surface area)
};

class Mesh : public Object {
  public:
    Mesh() = default;
    ObjectKind kind() const override { return ObjectKind::Mesh; }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override;
    void activate() override;
    std::string toString() const override;

    uint32_t triangleCount() const { return static_cast<uint32_t>(m_faces.cols()); }
    uint32_t vertexCount() const { return static_cast<uint32_t>(m_positions.cols()); }
    const Eigen::Matrix<float, 3, Eigen::Dynamic>& positions() const { return m_positions; }
    const Eigen::Matrix<float, 3, Eigen::Dynamic>& normals() const { return m_normals; }
    const Eigen::Matrix<float, 2, Eigen::Dynamic>& uvs() const { return m_uvs; }
    const Eigen::Matrix<uint32_t, 3, Eigen::Dynamic>& faces() const { return m_faces; }

    float triangleArea(uint32_t index) const;
    float surfaceArea() const { return m_surfaceArea; }
    Eigen::AlignedBox3f bounds() const;

    // The true normal of a triangle, unit length (UnitZ for a degenerate one).
    Normal3f geometricNormal(uint32_t triangle) const;
    // The same in world space, for the mesh placed by `instance`: the normal of the triangle's
    // corners placed in world space, as a mesh loaded with the instance's transform has it.
    Normal3f geometricNormal(uint32_t triangle, const Instance& instance) const;
    // Fills the hit record from a triangle index and barycentrics (u, v) as Embree reports them.
    void fillIntersection(uint32_t triangle, float u, float v, Intersection& its) const;
    // The same for the mesh placed by `instance` (the barycentrics of its object-space triangle,
    // which are those of the placed one): the record is in world space, the position, normals
    // and frame those of the triangle placed flat (common/scene/instance.h).
    void fillIntersection(uint32_t triangle, float u, float v, const Instance& instance,
                          Intersection& its) const;
    // Samples a point uniformly by area.
    SurfaceSample sampleSurface(const Point2f& sample) const;

    const BSDF* bsdf() const { return m_bsdf.get(); }
    const Emitter* emitter() const { return m_emitter.get(); }
    std::shared_ptr<Emitter> emitterShared() const { return m_emitter; }

    // Media on either side (<medium name="inside|outside">). "Inside" is the side opposite the
    // surface normal (the geometric normal, turned to agree with the interpolated one when the
    // mesh has normals). A side that is not given is vacuum (nullptr). A mesh that gives neither
    // is no medium boundary at all: rays keep the medium they were in (pbrt's rule), which is
    // what an opaque object standing in fog needs.
    bool hasMediumInterface() const { return m_hasMediumInterface; }
    const Medium* insideMedium() const { return m_inside.get(); }
    const Medium* outsideMedium() const { return m_outside.get(); }
    // The medium a ray is in after leaving the hit `its` along world direction `dir`, given the
    // medium `current` it arrived in. Reflection and refraction both follow from the side `dir`
    // points to.
    const Medium* mediumTowards(const Intersection& its, const Vector3f& dir,
                                const Medium* current) const;

  protected:
    // Called by loaders with the geometry; computes areas and the sampling table.
    void setGeometry(Eigen::Matrix<float, 3, Eigen::Dynamic> positions,
                     Eigen::Matrix<float, 3, Eigen::Dynamic> normals,
                     Eigen::Matrix<float, 2, Eigen::Dynamic> uvs,
                     Eigen::Matrix<uint32_t, 3, Eigen::Dynamic> faces);
    std::string m_name;

  private:
    // Where a triangle's corners are: positions, and normals and uvs where the mesh has them
    // (pointers into the vertex arrays, so that the inlined users read them without copies).
    struct Corners {
        const float *p[3], *n[3], *t[3];
        Eigen::Map<const Point3f> P(int k) const { return Eigen::Map<const Point3f>(p[k]); }
        Eigen::Map<const Normal3f> N(int k) const { return Eigen::Map<const Normal3f>(n[k]); }
        Eigen::Map<const Point2f> T(int k) const { return Eigen::Map<const Point2f>(t[k]); }
    };
    inline void corners(uint32_t triangle, Corners& c) const;
    // The hit record from the corners (in the space the record is to be in).
    inline void fillFromCorners(const Corners& c, uint32_t triangle, float u, float v,
                                Intersection& its) const;
    // The interpolated vertex normal at barycentrics (u, v, w), unit length; false if the mesh
    // has no normals or they cancel there.
    bool interpolatedNormal(const Corners& c, float u, float v, float w, Normal3f& normal) const;
    bool frameAlignedWithU(const Corners& c, const Normal3f& n, Frame& frame) const;

    Eigen::Matrix<float, 3, Eigen::Dynamic> m_positions;
    Eigen::Matrix<float, 3, Eigen::Dynamic> m_normals;  // empty when the file has none
    Eigen::Matrix<float, 2, Eigen::Dynamic> m_uvs;      // empty when the file has none
    Eigen::Matrix<uint32_t, 3, Eigen::Dynamic> m_faces;
    DiscretePDF m_areaPdf;
    float m_surfaceArea = 0.0f;
    float m_surfaceAreaPdf = 0.0f;  // 1 / m_surfaceArea, divided once

    std::shared_ptr<BSDF> m_bsdf;
    std::shared_ptr<Emitter> m_emitter;
    std::shared_ptr<Medium> m_inside, m_outside;
    bool m_hasMediumInterface = false;
    // Whether hits get the shading frame aligned with the uvs' u direction (the mesh has uvs
    // and its BSDF needs a tangent) or the one built from the normal alone.
    bool m_frameFollowsUvs = false;
};

inline Normal3f Intersection::geometricNormal() const {
    return instance ? mesh->geometricNormal(triangle, *instance) : mesh->geometricNormal(triangle);
}

// The most memory a mesh of `triangles` triangles and `vertices` vertices takes once the scene
// is built: its arrays (positions; normals and uvs when it has them; faces; the area sampling
// table) and, in the ray tracing structure, Embree's copy of positions and faces and its BVH.
// The BVH's share is what a scene of 18 million triangles measured, with some margin; the
// scene's total is checked against the memory allowed before any mesh is built.
uint64_t meshMemoryBytes(uint64_t triangles, uint64_t vertices, bool normals, bool uvs);

// The most vertices an OBJ face may have: tinyobjloader triangulates a polygon by ear clipping,
// in time quadratic in its vertices (a face of 90000 vertices took 14 s, one of 4096 about
// 0.05 s).
constexpr size_t kMaxObjFaceVertices = 4096;

// The most triangulation work an OBJ file may take: the sum of n^2 over its faces of n > 4
// vertices (tinyobjloader splits triangles and quads at once and ear-clips the others), at most
// that of 8 faces of kMaxObjFaceVertices. Without it a file of many such faces took 0.04 s a
// face; the repository's scenes have no face of more than 4 vertices.
constexpr uint64_t kMaxObjTriangulationWork = 8 * kMaxObjFaceVertices * kMaxObjFaceVertices;

// The most triangulation work (in the same units) a scene's OBJ files may take together, each
// file counted once however many <mesh> elements name it: twice a file's bound, about a second.
// Without it a scene naming many files, each just within kMaxObjTriangulationWork, took 0.4 s a
// file.
constexpr uint64_t kMaxSceneTriangulationWork = 2 * kMaxObjTriangulationWork;

// The OBJ loader's pass over the text before tinyobjloader reads it (obj_mesh.cpp): refuses,
// with "`name`:LINE: problem", the first line tinyobjloader would misread without a word (a
// number that is not a finite decimal one, a wrong count of numbers, a face index that is not
// an integer within int's range, a NUL byte) or would take too long over (a face of more than
// kMaxObjFaceVertices, or the face with which the file's faces go beyond
// kMaxObjTriangulationWork), and empties the "vw" (skin weight) lines, which Alphorn ignores and
// tinyobjloader parses unsafely.
struct ObjText {
    std::string text;      // the file as tinyobjloader is to read it
    size_t faceCount = 0;  // its "f" lines
};
ObjText preparedForTinyObj(std::string text, const std::string& name);

// What an OBJ file's mesh will have, counted by the same pass without building anything.
struct ObjCounts {
    uint64_t faces = 0;      // "f" lines
    uint64_t triangles = 0;  // a polygon of n vertices makes n - 2 (fewer if some are degenerate)
    // Distinct (position, uv, normal) index triples of the faces: the mesh's vertices.
    uint64_t vertices = 0;
    bool normals = true, uvs = true;  // whether every face vertex has one (the mesh keeps them)
    // The sum of n^2 over the faces of n > 4 vertices (see kMaxObjTriangulationWork).
    uint64_t triangulationWork = 0;

    uint64_t memoryBytes() const { return meshMemoryBytes(triangles, vertices, normals, uvs); }
};
// Throws Error("`name`:LINE: problem") as preparedForTinyObj does.
ObjCounts countObjText(std::string text, const std::string& name);
// The same for a file; a file that cannot be read throws Error naming it.
ObjCounts countObjFile(const std::string& path);

// The counts and the text as preparedForTinyObj gives it, from one read of the file and one
// pass over it: what the scene parser counts is what the mesh is then built from.
struct CountedObj {
    ObjCounts counts;
    ObjText prepared;
};
CountedObj countedAndPreparedObjText(std::string text, const std::string& name);
CountedObj countedAndPreparedObjFile(const std::string& path);

}  // namespace alphorn
