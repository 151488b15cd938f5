#include "common/scene/triangle_mesh.h"

#include "common/bsdf/bsdf.h"
#include "common/core/error.h"

#include <gtest/gtest.h>

namespace alphorn {
namespace {

TriangleGeometry square() {
    TriangleGeometry g;
    g.positions.resize(3, 4);
    g.positions << 0, 1, 1, 0,  //
        0, 0, 2, 2,             //
        0, 0, 0, 0;
    g.normals = Eigen::Matrix<float, 3, Eigen::Dynamic>::Zero(3, 4);
    g.normals.row(2).setConstant(2.0f);
    g.uvs = g.positions.topRows<2>();
    g.faces.resize(3, 2);
    g.faces << 0, 0,  //
        1, 2,         //
        2, 3;
    return g;
}

void expectRefused(const TriangleGeometry& g, const std::string& problem) {
    try {
        checkGeometry(g, "scene.pbrt:4:1 (Shape \"trianglemesh\")");
        ADD_FAILURE() << "accepted; expected " << problem;
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()), "scene.pbrt:4:1 (Shape \"trianglemesh\"): " + problem);
    }
}

TEST(TriangleMesh, CheckGeometryRefusesBrokenArrays) {
    checkGeometry(square(), "fine");
    TriangleGeometry g = square();
    g.faces(1, 1) = 4;
    expectRefused(g, "triangle 1 uses vertex 4, but the mesh has 4 vertices");
    g = square();
    g.positions(0, 2) = INFINITY;
    expectRefused(g, "vertex 2 has a position that is not finite (inf, 2, 0)");
    g = square();
    g.positions(1, 3) = -2e15f;
    expectRefused(g,
                  "vertex 3 lies at (0, -2e+15, 0), farther out than 1e+15, where rays cannot be "
                  "traced");
    g = square();
    g.normals.conservativeResize(3, 3);
    expectRefused(g, "the mesh has 3 normals for 4 vertices (it needs one per vertex, or none)");
    g = square();
    g.uvs.resize(2, 5);
    g.uvs.setZero();
    expectRefused(g, "the mesh has 5 uvs for 4 vertices (it needs one per vertex, or none)");
    g = square();
    g.uvs(1, 0) = NAN;
    expectRefused(g, "vertex 0 has a uv that is not finite");
    g = square();
    g.faces.resize(3, 0);
    expectRefused(g, "the mesh has no triangles");
    // A degenerate triangle is no error.
    g = square();
    g.faces(2, 1) = 0;
    checkGeometry(g, "fine");
}

TEST(TriangleMesh, TransformGeometryMovesPointsAndNormals) {
    TriangleGeometry g = square();
    // A shear: normals go by the inverse transpose, not by the matrix.
    Matrix4f m = Matrix4f::Identity();
    m(0, 2) = 1.0f;  // x += z
    m(2, 3) = 5.0f;  // z += 5
    g.normals.col(1) = Eigen::Vector3f(1, 0, 1);
    g.normals.col(2).setZero();
    transformGeometry(g, Transform(m));
    EXPECT_EQ(g.positions.col(2), Eigen::Vector3f(1, 2, 5));
    EXPECT_LT((g.normals.col(0) - Eigen::Vector3f(0, 0, 1)).norm(), 1e-6f);
    // (1, 0, 1) under the inverse transpose of x += z: (1, 0, 0), normalised.
    EXPECT_LT((g.normals.col(1) - Eigen::Vector3f(1, 0, 0)).norm(), 1e-6f);
    EXPECT_EQ(g.normals.col(2), Eigen::Vector3f::Zero());
    EXPECT_EQ(g.uvs, square().uvs);
    // A scale of 1e-20 leaves the normals' squared length out of the float range: still unit.
    TriangleGeometry tiny = square();
    transformGeometry(tiny, Transform(Eigen::Affine3f(Eigen::Scaling(1e-20f)).matrix()));
    EXPECT_LT((tiny.normals.col(0) - Eigen::Vector3f(0, 0, 1)).norm(), 1e-6f);
}

// Turned over, a triangle's winding normal is reversed; its vertices and normals stay.
TEST(TriangleMesh, FlipWindingReversesTheWindingNormal) {
    TriangleGeometry g = square();
    flipWinding(g);
    for (Eigen::Index f = 0; f < g.faces.cols(); ++f) {
        const auto& p = g.positions;
        const Eigen::Vector3f n = (p.col(g.faces(1, f)) - p.col(g.faces(0, f)))
                                      .cross(p.col(g.faces(2, f)) - p.col(g.faces(0, f)));
        EXPECT_LT(n.z(), 0.0f);
    }
    EXPECT_EQ(g.faces.col(1), Eigen::Vector3<uint32_t>(0, 3, 2));
    EXPECT_EQ(g.normals, square().normals);
    flipWinding(g);
    EXPECT_EQ(g.faces, square().faces);
}

TEST(TriangleMesh, IsAMeshWithItsSourceAndChildren) {
    auto mesh =
        std::make_shared<TriangleMesh>(square(), "scene.pbrt:7:1 (Shape \"trianglemesh\")", "quad");
    EXPECT_EQ(mesh->source(), "scene.pbrt:7:1 (Shape \"trianglemesh\")");
    EXPECT_EQ(mesh->toString(), "mesh \"quad\" (4 vertices, 2 triangles)");
    EXPECT_FLOAT_EQ(mesh->surfaceArea(), 2.0f);
    PropertyList props("test (bsdf)");
    mesh->addChild(ObjectFactory::create(ObjectKind::BSDF, "mirror", props), "");
    mesh->activate();
    ASSERT_NE(mesh->bsdf(), nullptr);
    EXPECT_FALSE(mesh->bsdf()->isDiffuse());
    // A sample's normal is the interpolated one: +z, whatever its length in the arrays.
    EXPECT_LT((mesh->sampleSurface(Point2f(0.3f, 0.6f)).n - Eigen::Vector3f(0, 0, 1)).norm(),
              1e-6f);
    TriangleGeometry broken = square();
    broken.faces(0, 0) = 9;
    EXPECT_THROW(TriangleMesh(broken, "here"), Error);
}

}  // namespace
}  // namespace alphorn
