#include "common/scene/quadrics.h"

#include "common/core/error.h"
#include "common/scene/bilinear_patches.h"

#include <gtest/gtest.h>

#include <cmath>

namespace alphorn {
namespace {

double area(const TriangleGeometry& g) {
    double sum = 0.0;
    for (Eigen::Index f = 0; f < g.faces.cols(); ++f) {
        const Eigen::Vector3d a = g.positions.col(g.faces(0, f)).cast<double>();
        const Eigen::Vector3d b = g.positions.col(g.faces(1, f)).cast<double>();
        const Eigen::Vector3d c = g.positions.col(g.faces(2, f)).cast<double>();
        sum += 0.5 * (b - a).cross(c - a).norm();
    }
    return sum;
}

Eigen::Vector3d windingNormal(const TriangleGeometry& g, Eigen::Index f) {
    const Eigen::Vector3d a = g.positions.col(g.faces(0, f)).cast<double>();
    const Eigen::Vector3d b = g.positions.col(g.faces(1, f)).cast<double>();
    const Eigen::Vector3d c = g.positions.col(g.faces(2, f)).cast<double>();
    return (b - a).cross(c - a);
}

// The checks every tessellation passes: arrays of one size, unit normals, no degenerate
// triangle, and each triangle wound to agree with its vertices' normals.
void expectWellFormed(const TriangleGeometry& g) {
    ASSERT_EQ(g.normals.cols(), g.positions.cols());
    ASSERT_EQ(g.uvs.cols(), g.positions.cols());
    for (Eigen::Index v = 0; v < g.normals.cols(); ++v)
        EXPECT_NEAR(g.normals.col(v).norm(), 1.0f, 1e-6f);
    for (Eigen::Index f = 0; f < g.faces.cols(); ++f) {
        const Eigen::Vector3d n = windingNormal(g, f);
        EXPECT_GT(n.norm(), 0.0) << f;
        for (int k = 0; k < 3; ++k)
            EXPECT_GT(n.dot(g.normals.col(g.faces(k, f)).cast<double>()), 0.0) << f;
    }
}

// The exact areas are pbrt's: phimax r (zmax - zmin) for a sphere or a cylinder, phimax / 2
// (r^2 - ri^2) for a disk. The triangles are inscribed, so their area is a little less.
void expectAreaWithinATenthOfAPercent(const TriangleGeometry& g, double exact) {
    const double ratio = area(g) / exact;
    EXPECT_LT(ratio, 1.0);
    EXPECT_GT(ratio, 0.999);
}

TEST(Quadrics, SphereAreaAndSilhouette) {
    const double r = 2.5;
    const TriangleGeometry g = tessellateSphere(float(r), -10.0f, 10.0f, 360.0f);
    expectWellFormed(g);
    expectAreaWithinATenthOfAPercent(g, 4.0 * M_PI * r * r);
    // Every point of a triangle is at least as far from the centre as the triangle's plane: the
    // surface is within 0.1% of the radius everywhere, not just at the centroids.
    double worst = 0.0;
    for (Eigen::Index f = 0; f < g.faces.cols(); ++f) {
        const Eigen::Vector3d n = windingNormal(g, f).normalized();
        const double plane = n.dot(g.positions.col(g.faces(0, f)).cast<double>());
        EXPECT_GT(plane, 0.0);  // facing out
        worst = std::max(worst, (r - plane) / r);
    }
    EXPECT_LT(worst, 0.001);
    EXPECT_GT(worst, 0.0001);  // not a far finer tessellation than the header states
    for (Eigen::Index v = 0; v < g.positions.cols(); ++v) {
        EXPECT_NEAR(g.positions.col(v).norm(), r, 1e-5 * r);
        EXPECT_LT((g.normals.col(v) - g.positions.col(v).normalized()).norm(), 1e-5f);
    }
}

// pbrt's (u, v): u = phi / phimax, v = (theta - theta(zmin)) / (theta(zmax) - theta(zmin)).
TEST(Quadrics, PartialSphereKeepsPbrtsParameterisation) {
    const float zmin = -0.5f, zmax = 0.8f, phimax = 270.0f;
    // zmin and zmax are put in order, as pbrt does.
    const TriangleGeometry g = tessellateSphere(1.0f, zmax, zmin, phimax);
    expectWellFormed(g);
    const double phiMax = 1.5 * M_PI;
    expectAreaWithinATenthOfAPercent(g, phiMax * (zmax - zmin));
    const double thetaZMin = std::acos(double(zmin)), thetaZMax = std::acos(double(zmax));
    for (Eigen::Index v = 0; v < g.positions.cols(); ++v) {
        const Eigen::Vector3f p = g.positions.col(v);
        EXPECT_GE(p.z(), zmin - 1e-6f);
        EXPECT_LE(p.z(), zmax + 1e-6f);
        double phi = std::atan2(double(p.y()), double(p.x()));
        if (phi < 0) phi += 2.0 * M_PI;
        // The seam at phi = 0 is the vertex of u = 0 (or of u = 1 at a full circle).
        if (g.uvs(0, v) > 1e-6f) {
            EXPECT_NEAR(g.uvs(0, v), phi / phiMax, 1e-5) << v;
        }
        const double theta = std::acos(std::clamp(double(p.z()), -1.0, 1.0));
        EXPECT_NEAR(g.uvs(1, v), (theta - thetaZMin) / (thetaZMax - thetaZMin), 1e-4) << v;
    }
    // The same sphere clamped from beyond its radius is the full sphere.
    const TriangleGeometry full = tessellateSphere(1.0f, -1.0f, 1.0f, 360.0f);
    const TriangleGeometry clamped = tessellateSphere(1.0f, 3.0f, -7.0f, 400.0f);
    EXPECT_EQ(full.positions, clamped.positions);
    EXPECT_EQ(full.faces, clamped.faces);
    // A thin sliver still gets cells: a cap of 1 degree, a wedge of 2.
    const TriangleGeometry sliver = tessellateSphere(1.0f, 0.9998f, 1.0f, 2.0f);
    expectWellFormed(sliver);
    expectAreaWithinATenthOfAPercent(sliver, 2.0 * M_PI / 180.0 * 0.0002);
}

TEST(Quadrics, DiskAreaRimAndParameterisation) {
    const double radius = 2.0, inner = 0.5, height = 0.25;
    const TriangleGeometry g = tessellateDisk(float(height), float(radius), float(inner), 300.0f);
    expectWellFormed(g);
    expectAreaWithinATenthOfAPercent(
        g, 300.0 / 180.0 * M_PI / 2.0 * (radius * radius - inner * inner));
    double worst = 0.0;
    for (Eigen::Index f = 0; f < g.faces.cols(); ++f) {
        EXPECT_GT(windingNormal(g, f).z(), 0.0);
        // The rim's chords: how far in from the circle their lines pass.
        for (int k = 0; k < 3; ++k) {
            const Eigen::Vector2d a = g.positions.col(g.faces(k, f)).head<2>().cast<double>();
            const Eigen::Vector2d b =
                g.positions.col(g.faces((k + 1) % 3, f)).head<2>().cast<double>();
            if (std::abs(a.norm() - radius) > 1e-5 || std::abs(b.norm() - radius) > 1e-5) continue;
            const double distance = std::abs(a.x() * b.y() - a.y() * b.x()) / (b - a).norm();
            worst = std::max(worst, (radius - distance) / radius);
        }
    }
    EXPECT_GT(worst, 0.0);
    EXPECT_LT(worst, 0.001);
    for (Eigen::Index v = 0; v < g.positions.cols(); ++v) {
        EXPECT_EQ(g.positions(2, v), float(height));
        EXPECT_EQ(g.normals.col(v), Eigen::Vector3f::UnitZ());
        const double rho = g.positions.col(v).head<2>().norm();
        EXPECT_NEAR(g.uvs(1, v), (radius - rho) / (radius - inner), 1e-5);
    }
    // Without a hole the centre is a point, and no triangle is degenerate there.
    const TriangleGeometry full = tessellateDisk(0.0f, 1.0f, 0.0f, 360.0f);
    expectWellFormed(full);
    expectAreaWithinATenthOfAPercent(full, M_PI);
}

TEST(Quadrics, CylinderAreaAndSilhouette) {
    const double r = 1.5;
    const TriangleGeometry g = tessellateCylinder(float(r), 1.0f, -2.0f, 360.0f);
    expectWellFormed(g);
    expectAreaWithinATenthOfAPercent(g, 2.0 * M_PI * r * 3.0);
    double worst = 0.0;
    for (Eigen::Index f = 0; f < g.faces.cols(); ++f) {
        // The triangle's plane is vertical: its distance from the axis bounds the silhouette.
        const Eigen::Vector3d n = windingNormal(g, f).normalized();
        EXPECT_NEAR(n.z(), 0.0, 1e-6);
        const double distance = n.dot(g.positions.col(g.faces(0, f)).cast<double>());
        worst = std::max(worst, (r - distance) / r);
    }
    EXPECT_LT(worst, 0.001);
    for (Eigen::Index v = 0; v < g.positions.cols(); ++v) {
        const Eigen::Vector3f p = g.positions.col(v);
        EXPECT_NEAR(p.head<2>().norm(), r, 1e-5 * r);
        EXPECT_NEAR(g.uvs(1, v), (p.z() + 2.0) / 3.0, 1e-6);
        EXPECT_LT((g.normals.col(v) - Eigen::Vector3f(p.x(), p.y(), 0).normalized()).norm(), 1e-6f);
    }
    const TriangleGeometry half = tessellateCylinder(1.0f, 0.0f, 1.0f, 180.0f);
    expectAreaWithinATenthOfAPercent(half, M_PI);
    for (Eigen::Index v = 0; v < half.positions.cols(); ++v)
        EXPECT_GE(half.positions(1, v), -1e-6f);
}

TEST(Quadrics, RefuseShapesWithoutArea) {
    auto refused = [](auto make, const std::string& problem) {
        try {
            make();
            ADD_FAILURE() << "accepted; expected " << problem;
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(problem), std::string::npos) << e.what();
        }
    };
    refused([] { tessellateSphere(0.0f, -1.0f, 1.0f, 360.0f); },
            "sphere: the radius must be positive");
    refused([] { tessellateSphere(1.0f, std::nanf(""), 1.0f, 360.0f); },
            "sphere: zmin must be finite");
    refused([] { tessellateSphere(1.0f, 2.0f, 3.0f, 360.0f); }, "leave no area");
    refused([] { tessellateSphere(1.0f, -1.0f, 1.0f, -5.0f); }, "phimax is -5 degrees");
    refused([] { tessellateDisk(0.0f, 1.0f, 1.0f, 360.0f); },
            "disk: needs 0 <= innerradius < radius");
    refused([] { tessellateDisk(0.0f, -1.0f, 0.0f, 360.0f); }, "disk: needs");
    refused([] { tessellateCylinder(1.0f, 2.0f, 2.0f, 360.0f); }, "cylinder has no area");
    refused([] { tessellateCylinder(INFINITY, 0.0f, 2.0f, 360.0f); }, "radius must be finite");
}

// A planar patch is two exact triangles; without uvs each patch's corners get pbrt's (u, v).
TEST(BilinearPatches, PlanarPatchesAreExact) {
    Eigen::Matrix<float, 3, Eigen::Dynamic> p(3, 6);
    // Two patches sharing an edge: a 2 x 1 rectangle and a parallelogram beside it.
    p << 0, 2, 0, 2, 3, 3,     //
        0, 0, 1, 1, 0.5, 1.5,  //
        0, 0, 0, 0, 0, 0;
    const std::vector<uint32_t> indices = {0, 1, 2, 3, 1, 4, 3, 5};
    const TriangleGeometry g =
        bilinearPatchesAsTriangles(p, indices, {}, {}, "scene.pbrt:1:1 (Shape \"bilinearmesh\")");
    ASSERT_EQ(g.faces.cols(), 4);
    EXPECT_NEAR(area(g), 2.0 + 1.0, 1e-6);
    for (Eigen::Index f = 0; f < g.faces.cols(); ++f) {
        // pbrt's normal dp/du x dp/dv is +z for both.
        EXPECT_GT(windingNormal(g, f).z(), 0.0);
        EXPECT_NEAR(windingNormal(g, f).x(), 0.0, 1e-9);
    }
    ASSERT_EQ(g.uvs.cols(), 8);
    for (int patch = 0; patch < 2; ++patch) {
        EXPECT_EQ(g.uvs.col(4 * patch + 1), Eigen::Vector2f(1, 0));
        EXPECT_EQ(g.uvs.col(4 * patch + 2), Eigen::Vector2f(0, 1));
        EXPECT_EQ(g.positions.col(4 * patch + 3), p.col(indices[4 * patch + 3]));
    }
    EXPECT_EQ(g.normals.cols(), 0);
    // Given uvs and normals are the corners'.
    Eigen::Matrix<float, 2, Eigen::Dynamic> uv = p.topRows<2>() * 0.5f;
    Eigen::Matrix<float, 3, Eigen::Dynamic> n = Eigen::Matrix<float, 3, Eigen::Dynamic>::Zero(3, 6);
    n.row(2).setOnes();
    const TriangleGeometry h = bilinearPatchesAsTriangles(p, indices, uv, n, "test");
    EXPECT_EQ(h.uvs.col(5), uv.col(4));
    EXPECT_EQ(h.normals.col(5), Eigen::Vector3f(0, 0, 1));
    // A warped patch: the two triangles meet along p00-p11, off the patch's centre by half the
    // distance between its diagonals' midpoints.
    Eigen::Matrix<float, 3, Eigen::Dynamic> w(3, 4);
    w << 0, 1, 0, 1,  //
        0, 0, 1, 1,   //
        0, 0, 0, 1;
    const TriangleGeometry warped = bilinearPatchesAsTriangles(w, {0, 1, 2, 3}, {}, {}, "test");
    EXPECT_NEAR(area(warped), std::sqrt(2.0), 1e-6);
    EXPECT_EQ(warped.faces(0, 0), 0u);
    EXPECT_EQ(warped.faces(2, 0), 3u);
    EXPECT_EQ(warped.faces(0, 1), 0u);
    EXPECT_EQ(warped.faces(1, 1), 3u);
    auto refusedWith = [&](const std::vector<uint32_t>& bad, const std::string& problem) {
        try {
            bilinearPatchesAsTriangles(p, bad, {}, {}, "here");
            ADD_FAILURE();
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("here: " + problem), std::string::npos)
                << e.what();
        }
    };
    refusedWith({0, 1, 2}, "the bilinear mesh has 3 vertex indices");
    refusedWith({0, 1, 2, 6}, "patch 0 uses vertex 6");
    refusedWith({}, "the bilinear mesh has no patches");
}

}  // namespace
}  // namespace alphorn
