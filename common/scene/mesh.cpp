#include "common/scene/mesh.h"

#include "common/bsdf/bsdf.h"
#include "common/core/warp.h"
#include "common/emitter/emitter.h"
#include "common/medium/medium.h"
#include "common/scene/instance.h"

#include <absl/strings/str_format.h>

#include <iostream>

namespace alphorn {

uint64_t meshMemoryBytes(uint64_t triangles, uint64_t vertices, bool normals, bool uvs) {
    // Embree's BVH over the triangles, with its build's working memory: a scene of 2000 spheres
    // (18 million triangles, 9.5 million vertices) peaked at 2.86 GB, about 158 bytes a triangle
    // in all, of which the arrays below take 55 and the BVH the rest (about 102, here with some
    // margin).
    constexpr uint64_t kBvhBytesPerTriangle = 112;
    const uint64_t perVertex = sizeof(float) * (3 + (normals ? 3 : 0) + (uvs ? 2 : 0)) +
                               sizeof(float) * 3;  // Embree's copy of the positions
    const uint64_t perTriangle = sizeof(uint32_t) * 3 + sizeof(double) +  // faces, area table
                                 sizeof(uint32_t) * 3 +  // Embree's copy of the faces
                                 kBvhBytesPerTriangle;
    return vertices * perVertex + triangles * perTriangle;
}

void Mesh::setGeometry(Eigen::Matrix<float, 3, Eigen::Dynamic> positions,
                       Eigen::Matrix<float, 3, Eigen::Dynamic> normals,
                       Eigen::Matrix<float, 2, Eigen::Dynamic> uvs,
                       Eigen::Matrix<uint32_t, 3, Eigen::Dynamic> faces) {
    m_positions = std::move(positions);
    m_normals = std::move(normals);
    m_uvs = std::move(uvs);
    m_faces = std::move(faces);
    m_areaPdf.clear();
    m_areaPdf.reserve(triangleCount());
    for (uint32_t i = 0; i < triangleCount(); ++i) m_areaPdf.append(triangleArea(i));
    m_surfaceArea = static_cast<float>(m_areaPdf.normalize());
    m_surfaceAreaPdf = 1.0f / m_surfaceArea;
}

inline void Mesh::corners(uint32_t triangle, Corners& c) const {
    for (int k = 0; k < 3; ++k) {
        const uint32_t i = m_faces(k, triangle);
        c.p[k] = m_positions.data() + 3 * size_t(i);
        if (m_normals.cols() > 0) c.n[k] = m_normals.data() + 3 * size_t(i);
        if (m_uvs.cols() > 0) c.t[k] = m_uvs.data() + 2 * size_t(i);
    }
}

void Mesh::addChild(const std::shared_ptr<Object>& child, const std::string& name) {
    switch (child->kind()) {
        case ObjectKind::BSDF:
            if (m_bsdf) fail("the mesh has more than one BSDF");
            m_bsdf = std::static_pointer_cast<BSDF>(child);
            break;
        case ObjectKind::Emitter:
            // A point, spot or projector light is a light of its own: nested, it would mark the
            // mesh as emitting (its surface would be looked up as this light) without any
            // surface emitting.
            if (std::static_pointer_cast<Emitter>(child)->isDelta())
                child->fail(
                    "a point-like light (point, spotlight, projector) cannot be nested in a "
                    "<mesh>, which only takes an area emitter; give it in the <scene>");
            if (m_emitter) fail("the mesh has more than one emitter");
            m_emitter = std::static_pointer_cast<Emitter>(child);
            m_emitter->setMesh(this);
            break;
        case ObjectKind::Medium: {
            if (name != "inside" && name != "outside")
                child->fail("a medium nested in a mesh needs name=\"inside\" or name=\"outside\"");
            auto& slot = name == "inside" ? m_inside : m_outside;
            if (slot) child->fail("the mesh has more than one %s medium", name);
            slot = std::static_pointer_cast<Medium>(child);
            m_hasMediumInterface = true;
            break;
        }
        default:
            Object::addChild(child, name);
    }
}

void Mesh::activate() {
    if (!m_bsdf) {
        // Nori's default: a diffuse BSDF of albedo 0.5.
        PropertyList props(source() + " (default bsdf)");
        m_bsdf = std::static_pointer_cast<BSDF>(
            ObjectFactory::create(ObjectKind::BSDF, "diffuse", props));
        m_bsdf->activate();
    }
    // A light of zero area (all its triangles degenerate, or too small for their area to be a
    // float) renders: it is never hit, never chosen by power, and its light samples carry
    // nothing, so the image is the scene's without it. Nothing to refuse, but likely not meant.
    if (m_emitter && !(m_surfaceArea > 0.0f))
        std::cerr << absl::StrFormat(
            "warning: %s: the mesh carries an area emitter but has zero surface area; it emits "
            "nothing\n",
            source());
    m_frameFollowsUvs = m_uvs.cols() > 0 && m_bsdf->needsTangentFrame();
}

float Mesh::triangleArea(uint32_t index) const {
    const Point3f& p0 = m_positions.col(m_faces(0, index));
    const Point3f& p1 = m_positions.col(m_faces(1, index));
    const Point3f& p2 = m_positions.col(m_faces(2, index));
    return 0.5f * (p1 - p0).cross(p2 - p0).norm();
}

Eigen::AlignedBox3f Mesh::bounds() const {
    Eigen::AlignedBox3f box;
    for (uint32_t i = 0; i < vertexCount(); ++i) box.extend(Vector3f(m_positions.col(i)));
    return box;
}

namespace {

// The true normal of triangle (p0, p1, p2), unit length. Degenerate triangles still get a valid
// normal so nothing downstream divides by zero.
Normal3f unitGeometricNormal(const Point3f& p0, const Point3f& p1, const Point3f& p2) {
    Vector3f geometric = (p1 - p0).cross(p2 - p0);
    float length = geometric.norm();
    return length > 0.0f ? Vector3f(geometric / length) : Vector3f::UnitZ();
}

}  // namespace

Normal3f Mesh::geometricNormal(uint32_t triangle) const {
    return unitGeometricNormal(m_positions.col(m_faces(0, triangle)),
                               m_positions.col(m_faces(1, triangle)),
                               m_positions.col(m_faces(2, triangle)));
}

inline bool Mesh::interpolatedNormal(const Corners& c, float u, float v, float w,
                                     Normal3f& normal) const {
    if (m_normals.cols() == 0) return false;
    Vector3f n = w * c.N(0) + u * c.N(1) + v * c.N(2);
    float nl = n.norm();
    if (!(nl > 0.0f && std::isfinite(nl))) return false;
    normal = n / nl;
    return true;
}

Normal3f Mesh::geometricNormal(uint32_t triangle, const Instance& instance) const {
    return unitGeometricNormal(instance.pointToWorld(m_positions.col(m_faces(0, triangle))),
                               instance.pointToWorld(m_positions.col(m_faces(1, triangle))),
                               instance.pointToWorld(m_positions.col(m_faces(2, triangle))));
}

inline void Mesh::fillFromCorners(const Corners& c, uint32_t triangle, float u, float v,
                                  Intersection& its) const {
    const float w = 1.0f - u - v;
    its.mesh = this;
    its.triangle = triangle;
    its.p = w * c.P(0) + u * c.P(1) + v * c.P(2);
    if (m_uvs.cols() > 0)
        its.uv = w * c.T(0) + u * c.T(1) + v * c.T(2);
    else
        its.uv = Point2f(u, v);

    Normal3f shading;
    if (!interpolatedNormal(c, u, v, w, shading))
        shading = unitGeometricNormal(c.P(0), c.P(1), c.P(2));
    // Where the BSDF needs a tangent (and the mesh has uvs) it follows u, and the frame built
    // from the normal alone is only the fallback where the uvs are degenerate. Elsewhere that
    // frame is the whole answer: it costs one division against the aligned frame's dp/du, dp/dv
    // and normalisation (about 3% of a Cornell box render's CPU time).
    if (m_frameFollowsUvs && frameAlignedWithU(c, shading, its.shFrame)) return;
    its.shFrame = Frame(shading);
}

void Mesh::fillIntersection(uint32_t triangle, float u, float v, Intersection& its) const {
    Corners c;
    corners(triangle, c);
    its.instance = nullptr;
    fillFromCorners(c, triangle, u, v, its);
}

// The corners are placed in world space first and then interpolated, as for the mesh loaded with
// the instance's transform, rather than the object-space hit transformed: that gives the flat
// mesh's floats (exactly, where the placement is exact), and the frame follows the world-space
// dp/du of the placed triangle.
void Mesh::fillIntersection(uint32_t triangle, float u, float v, const Instance& instance,
                            Intersection& its) const {
    Corners c;
    corners(triangle, c);
    float positions[3][3], normals[3][3];
    for (int k = 0; k < 3; ++k) {
        Eigen::Map<Point3f>{positions[k]} = instance.pointToWorld(c.P(k));
        c.p[k] = positions[k];
        if (m_normals.cols() > 0) {
            Eigen::Map<Normal3f>{normals[k]} = instance.unitNormalToWorld(c.N(k));
            c.n[k] = normals[k];
        }
    }
    its.instance = &instance;
    fillFromCorners(c, triangle, u, v, its);
}

// Builds the frame about normal n whose tangent s points along dp/du, with its bitangent t
// pointed to the side of dp/dv: tangent-space data (normal maps: red along +u, green along +v)
// then keeps its orientation relative to the texture on any mesh. Where the uv mapping is
// mirrored (dp/du x dp/dv against the normal) this makes the frame left-handed, which every use
// of a frame allows: it is only ever used through dot products and their inverse. Returns false,
// leaving `frame` alone, where the uvs are degenerate.
bool Mesh::frameAlignedWithU(const Corners& c, const Normal3f& n, Frame& frame) const {
    const Vector2f duv02 = c.T(0) - c.T(2), duv12 = c.T(1) - c.T(2);
    const float det = duv02.x() * duv12.y() - duv02.y() * duv12.x();
    if (!(std::abs(det) > 1e-12f)) return false;
    const Vector3f dp02 = c.P(0) - c.P(2);
    const Vector3f dp12 = c.P(1) - c.P(2);
    const Vector3f dpdu = (duv12.y() * dp02 - duv02.y() * dp12) / det;
    Vector3f s = dpdu - n * n.dot(dpdu);
    const float length = s.norm();
    if (!(length > 1e-12f) || !std::isfinite(length)) return false;
    s /= length;
    const Vector3f dpdv = (duv02.x() * dp12 - duv12.x() * dp02) / det;
    const Vector3f t = n.cross(s);
    frame = Frame(s, t.dot(dpdv) < 0.0f ? Vector3f(-t) : t, n);
    return true;
}

const Medium* Mesh::mediumTowards(const Intersection& its, const Vector3f& dir,
                                  const Medium* current) const {
    if (!m_hasMediumInterface) return current;
    Vector3f outward = its.geometricNormal();
    if (outward.dot(its.shFrame.n) < 0.0f) outward = -outward;
    return dir.dot(outward) < 0.0f ? m_inside.get() : m_outside.get();
}

// The same position, normal and uv as fillIntersection gives, without the frames (a light
// sample needs only the normal).
SurfaceSample Mesh::sampleSurface(const Point2f& sample) const {
    float u = sample.x();
    uint32_t triangle = static_cast<uint32_t>(m_areaPdf.sampleReuse(u));
    Point2f bary = warp::squareToUniformTriangle(Point2f(u, sample.y()));
    const float bu = bary.x(), bv = bary.y(), w = 1.0f - bu - bv;
    Corners c;
    corners(triangle, c);
    SurfaceSample s;
    s.p = w * c.P(0) + bu * c.P(1) + bv * c.P(2);
    if (!interpolatedNormal(c, bu, bv, w, s.n)) s.n = unitGeometricNormal(c.P(0), c.P(1), c.P(2));
    if (m_uvs.cols() > 0)
        s.uv = w * c.T(0) + bu * c.T(1) + bv * c.T(2);
    else
        s.uv = Point2f(bu, bv);
    s.pdf = m_surfaceAreaPdf;
    return s;
}

std::string Mesh::toString() const {
    return absl::StrFormat("mesh \"%s\" (%u vertices, %u triangles)", m_name, vertexCount(),
                           triangleCount());
}

}  // namespace alphorn
