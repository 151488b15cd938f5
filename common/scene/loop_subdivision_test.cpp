#include "common/scene/loop_subdivision.h"

#include "common/core/error.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <set>

namespace alphorn {
namespace {

using Positions = Eigen::Matrix<float, 3, Eigen::Dynamic>;
using Faces = Eigen::Matrix<uint32_t, 3, Eigen::Dynamic>;

// The faces of a convex polyhedron whose vertices are `points` and whose faces are the
// triangles of three vertices at `edge` from each other, wound counter-clockwise seen from
// outside (the winding normal points away from the centre).
Faces convexFaces(const Positions& points, float edge) {
    auto isEdge = [&](int a, int b) {
        return std::abs((points.col(a) - points.col(b)).norm() - edge) < 1e-4f;
    };
    std::vector<uint32_t> faces;
    const int n = int(points.cols());
    for (int a = 0; a < n; ++a)
        for (int b = a + 1; b < n; ++b)
            for (int c = b + 1; c < n; ++c) {
                if (!isEdge(a, b) || !isEdge(b, c) || !isEdge(a, c)) continue;
                const Eigen::Vector3f normal =
                    (points.col(b) - points.col(a)).cross(points.col(c) - points.col(a));
                if (normal.dot(points.col(a)) > 0)
                    faces.insert(faces.end(), {uint32_t(a), uint32_t(b), uint32_t(c)});
                else
                    faces.insert(faces.end(), {uint32_t(a), uint32_t(c), uint32_t(b)});
            }
    Faces result(3, faces.size() / 3);
    std::copy(faces.begin(), faces.end(), result.data());
    return result;
}

Positions icosahedron() {
    const float g = (1.0f + std::sqrt(5.0f)) / 2.0f;
    Positions p(3, 12);
    int i = 0;
    for (float s : {-1.0f, 1.0f})
        for (float t : {-g, g}) {
            p.col(i++) = Eigen::Vector3f(0, s, t);
            p.col(i++) = Eigen::Vector3f(s, t, 0);
            p.col(i++) = Eigen::Vector3f(t, 0, s);
        }
    return p;
}

Positions tetrahedron() {
    Positions p(3, 4);
    p << 1, 1, -1, -1,  //
        1, -1, 1, -1,   //
        1, -1, -1, 1;
    return p;
}

Positions octahedron() {
    Positions p(3, 6);
    p << 1, -1, 0, 0, 0, 0,  //
        0, 0, 1, -1, 0, 0,   //
        0, 0, 0, 0, 1, -1;
    return p;
}

Eigen::Vector3f windingNormal(const TriangleGeometry& g, Eigen::Index f) {
    const auto& p = g.positions;
    return (p.col(g.faces(1, f)) - p.col(g.faces(0, f)))
        .cross(p.col(g.faces(2, f)) - p.col(g.faces(0, f)));
}

// Each round adds a vertex per edge and splits each face into four; on a closed mesh each face
// has three edges, each shared by two faces.
TEST(LoopSubdivision, CountsVerticesAndFacesOnClosedMeshes) {
    for (const Positions& p : {icosahedron(), octahedron(), tetrahedron()}) {
        const Faces faces = convexFaces(p, p.cols() == 12  ? 2.0f
                                           : p.cols() == 6 ? std::sqrt(2.0f)
                                                           : std::sqrt(8.0f));
        ASSERT_EQ(p.cols() - 3 * faces.cols() / 2 + faces.cols(), 2);  // Euler: V - E + F
        uint64_t vertices = p.cols(), edges = 3 * faces.cols() / 2, triangles = faces.cols();
        for (int levels = 0; levels <= 3; ++levels) {
            const TriangleGeometry g = loopSubdivide(p, faces, levels, "test");
            EXPECT_EQ(uint64_t(g.positions.cols()), vertices);
            EXPECT_EQ(uint64_t(g.normals.cols()), vertices);
            EXPECT_EQ(uint64_t(g.faces.cols()), triangles);
            EXPECT_EQ(g.uvs.cols(), 0);
            vertices += edges;
            edges = 2 * edges + 3 * triangles;
            triangles *= 4;
        }
    }
}

// A regular tetrahedron about the origin, not subdivided: each vertex has valence 3, so beta =
// 3/16 and gamma = 1/5, and its neighbours add up to minus itself: the limit is 2/5 p - 1/5 p =
// p / 5. The limit normal lies along p by symmetry, on the side opposite the winding (pbrt's).
TEST(LoopSubdivision, TetrahedronGoesToAFifthOfItself) {
    const Positions p = tetrahedron();
    const TriangleGeometry g = loopSubdivide(p, convexFaces(p, std::sqrt(8.0f)), 0, "test");
    ASSERT_EQ(g.positions.cols(), 4);
    for (int v = 0; v < 4; ++v) {
        EXPECT_LT((g.positions.col(v) - 0.2f * p.col(v)).norm(), 1e-6f) << v;
        EXPECT_LT((g.normals.col(v) + p.col(v).normalized()).norm(), 1e-6f) << v;
    }
}

// The largest angle (degrees) between a vertex's limit normal and the reversed mean winding
// normal of the faces around it: on a finely subdivided mesh the faces lie close to the limit
// surface, so the two agree where the normals are right (pbrt's, against the winding).
double worstNormalAngle(const TriangleGeometry& g) {
    Positions faceSum = Positions::Zero(3, g.positions.cols());
    for (Eigen::Index f = 0; f < g.faces.cols(); ++f)
        for (int k = 0; k < 3; ++k) faceSum.col(g.faces(k, f)) += windingNormal(g, f).normalized();
    double worst = 0.0;
    for (Eigen::Index v = 0; v < g.positions.cols(); ++v) {
        const double c = -g.normals.col(v).dot(faceSum.col(v).normalized());
        worst = std::max(worst, std::acos(std::min(1.0, c)) * 180.0 / M_PI);
    }
    return worst;
}

// The limit surface of an icosahedron is close to its circumscribed sphere's shape, though not
// one: every limit point lies within 3% of the mean radius (measured: 2.1% at 3 levels) and
// every normal within 5 degrees of the radial direction, pointing in (measured: 4.0 degrees).
// Each normal points against the winding of every face around it, and agrees with those faces
// to within 3 degrees.
TEST(LoopSubdivision, IcosahedronLimitIsNearlyASphere) {
    const Positions p = icosahedron();
    const TriangleGeometry g = loopSubdivide(p, convexFaces(p, 2.0f), 3, "test");
    double mean = 0.0;
    for (Eigen::Index v = 0; v < g.positions.cols(); ++v) mean += g.positions.col(v).norm();
    mean /= double(g.positions.cols());
    double spread = 0.0, worstCos = 1.0;
    for (Eigen::Index v = 0; v < g.positions.cols(); ++v) {
        spread = std::max(spread, std::abs(g.positions.col(v).norm() / mean - 1.0));
        worstCos =
            std::min(worstCos, double(-g.normals.col(v).dot(g.positions.col(v).normalized())));
        EXPECT_NEAR(g.normals.col(v).norm(), 1.0f, 1e-5f);
    }
    EXPECT_LT(spread, 0.03);
    EXPECT_GT(worstCos, std::cos(5.0 * M_PI / 180.0));
    EXPECT_LT(worstNormalAngle(g), 3.0);
    for (Eigen::Index f = 0; f < g.faces.cols(); ++f)
        for (int k = 0; k < 3; ++k)
            EXPECT_LT(windingNormal(g, f).dot(g.normals.col(g.faces(k, f))), 0.0f);
}

// An n x n grid of vertices at (i, j, height(i, j)), each cell two triangles wound
// counter-clockwise about +z; vertex (i, j) is number j * n + i.
struct Grid {
    Positions positions;
    Faces faces;
};
template <typename Height>
Grid grid(int n, Height height) {
    Grid g;
    g.positions.resize(3, n * n);
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
            g.positions.col(j * n + i) = Eigen::Vector3f(i, j, height(i, j));
    g.faces.resize(3, 2 * (n - 1) * (n - 1));
    int f = 0;
    for (int j = 0; j + 1 < n; ++j)
        for (int i = 0; i + 1 < n; ++i) {
            const uint32_t a = j * n + i, b = a + 1, c = a + n + 1, d = a + n;
            g.faces.col(f++) << a, b, c;
            g.faces.col(f++) << a, c, d;
        }
    return g;
}

// The vertices on edges of one face only, each with its two neighbours along the boundary.
std::map<uint32_t, std::array<uint32_t, 2>> boundaryNeighbours(const Faces& faces) {
    std::map<std::pair<uint32_t, uint32_t>, int> edges;
    for (Eigen::Index f = 0; f < faces.cols(); ++f)
        for (int k = 0; k < 3; ++k) {
            const uint32_t a = faces(k, f), b = faces((k + 1) % 3, f);
            ++edges[{std::min(a, b), std::max(a, b)}];
        }
    std::map<uint32_t, std::vector<uint32_t>> lists;
    for (const auto& [edge, count] : edges)
        if (count == 1) {
            lists[edge.first].push_back(edge.second);
            lists[edge.second].push_back(edge.first);
        }
    std::map<uint32_t, std::array<uint32_t, 2>> result;
    for (const auto& [v, list] : lists) {
        EXPECT_EQ(list.size(), 2u);
        result[v] = {list[0], list[1]};
    }
    return result;
}

// A flat mesh stays in its plane, with normals across it: inside and along its boundary alike.
TEST(LoopSubdivision, AFlatGridStaysFlat) {
    const Grid flat = grid(6, [](int, int) { return 0.0f; });
    const TriangleGeometry g = loopSubdivide(flat.positions, flat.faces, 2, "test");
    ASSERT_EQ(g.faces.cols(), 16 * flat.faces.cols());
    for (Eigen::Index v = 0; v < g.positions.cols(); ++v) {
        EXPECT_EQ(g.positions(2, v), 0.0f);
        EXPECT_EQ(g.normals.col(v), Eigen::Vector3f(0, 0, -1)) << v;
        // Within the grid's square (the boundary rules cut its corners).
        EXPECT_GE(g.positions(0, v), 0.0f);
        EXPECT_LE(g.positions(0, v), 5.0f);
    }
    // A regular interior vertex of a flat regular grid is its own limit.
    EXPECT_EQ(g.positions.col(2 * 6 + 3), Eigen::Vector3f(3, 2, 0));
}

// The boundary follows its own rules: what lies inside does not move it. At level 0 a boundary
// vertex goes to 3/5 of itself and 1/5 of each boundary neighbour; with more levels, the input's
// boundary vertices approach the cubic B-spline curve of the boundary polygon, whose point at a
// vertex p between a and b is (a + 4p + b) / 6, by about 4 times a level (measured: 4.0 times,
// from 0.051 at level 0 to 0.00079 at level 3).
TEST(LoopSubdivision, BoundaryVerticesFollowTheBoundaryCurve) {
    auto bumpy = [](int i, int j) { return 0.3f * std::sin(1.7f * i) * std::cos(1.1f * j); };
    const Grid mesh = grid(7, bumpy);
    const Grid otherInside = grid(
        7, [&](int i, int j) { return i > 0 && j > 0 && i < 6 && j < 6 ? 2.0f : bumpy(i, j); });
    const auto original = boundaryNeighbours(mesh.faces);
    ASSERT_EQ(original.size(), 24u);
    double previousError = 0.0;
    for (int levels = 0; levels <= 3; ++levels) {
        const TriangleGeometry g = loopSubdivide(mesh.positions, mesh.faces, levels, "test");
        const TriangleGeometry h =
            loopSubdivide(otherInside.positions, otherInside.faces, levels, "test");
        const auto boundary = boundaryNeighbours(g.faces);
        EXPECT_EQ(boundary.size(), 24u << levels);
        for (const auto& [v, neighbours] : boundary)
            EXPECT_EQ(g.positions.col(v), h.positions.col(v));
        double error = 0.0;
        for (const auto& [v, n] : original) {
            const Eigen::Vector3f a = mesh.positions.col(n[0]), b = mesh.positions.col(n[1]),
                                  p = mesh.positions.col(v);
            if (levels == 0) {
                EXPECT_LT((g.positions.col(v) - (0.6f * p + 0.2f * (a + b))).norm(), 1e-6f);
            }
            error =
                std::max(error, double((g.positions.col(v) - (a + 4.0f * p + b) / 6.0f).norm()));
        }
        if (levels > 0) {
            EXPECT_LT(error, previousError / 3.0) << levels;
        }
        // Along the boundary too (valences 2 to 4 at the corners and edges), the limit normals
        // agree with the faces once these are fine.
        if (levels == 3) {
            EXPECT_LT(worstNormalAngle(g), 3.0);
        }
        previousError = error;
    }
    EXPECT_LT(previousError, 1e-3);
}

void expectRefused(const Positions& p, const Faces& faces, int levels, const std::string& problem) {
    try {
        loopSubdivide(p, faces, levels, "scene.pbrt:3:1 (Shape \"loopsubdiv\")");
        ADD_FAILURE() << "accepted; expected " << problem;
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_EQ(message.rfind("scene.pbrt:3:1 (Shape \"loopsubdiv\"): ", 0), 0u) << message;
        EXPECT_NE(message.find(problem), std::string::npos) << message;
    }
}

TEST(LoopSubdivision, RefusesWhatItCannotSubdivide) {
    const Positions p = icosahedron();
    const Faces faces = convexFaces(p, 2.0f);
    expectRefused(p, faces, -1, "levels must be 0 or more");
    expectRefused(p, faces, 12, "beyond the 16777216 allowed");
    expectRefused(p, faces, 1000, "beyond the 16777216 allowed");
    expectRefused(p, Faces(3, 0), 1, "no triangles");
    Faces outOfRange = faces;
    outOfRange(1, 7) = 12;
    expectRefused(p, outOfRange, 1, "triangle 7 uses vertex 12, but the mesh has 12 vertices");
    Faces twice = faces;
    twice(2, 3) = twice(0, 3);
    expectRefused(p, twice, 1, "triangle 3 uses vertex");
    Positions nan = p;
    nan(1, 4) = std::nanf("");
    expectRefused(nan, faces, 1, "vertex 4 has a position that is not finite");
    // A face turned over: its edges run the same way as its neighbours'.
    Faces flipped = faces;
    std::swap(flipped(1, 0), flipped(2, 0));
    expectRefused(p, flipped, 1, "not a consistently oriented manifold");
    // A third face on an edge.
    Positions fin(3, 5);
    fin << 0, 1, 0, 0, 0,  //
        0, 0, 1, -1, 0,    //
        0, 0, 0, 0, 1;
    Faces three(3, 3);
    three << 0, 1, 0,  //
        1, 0, 1,       //
        2, 3, 4;
    expectRefused(fin, three, 1, "not a consistently oriented manifold");
    // Two triangles meeting only at a vertex.
    Positions bow(3, 5);
    bow << 0, 1, 1, -1, -1,  //
        0, 0, 1, 0, -1,      //
        0, 0, 0, 0, 0;
    Faces bowtie(3, 2);
    bowtie << 0, 0,  //
        1, 3,        //
        2, 4;
    expectRefused(bow, bowtie, 1, "the faces around vertex 0 do not form a single fan");
}

// Vertices no face uses are left out, and the others keep their order.
TEST(LoopSubdivision, LeavesOutUnusedVertices) {
    const Positions p = tetrahedron();
    Positions padded(3, 6);
    padded << Eigen::Vector3f(9, 9, 9), p.col(0), p.col(1), Eigen::Vector3f(7, 7, 7), p.col(2),
        p.col(3);
    Faces faces = convexFaces(p, std::sqrt(8.0f));
    for (Eigen::Index f = 0; f < faces.cols(); ++f)
        for (int k = 0; k < 3; ++k) faces(k, f) += faces(k, f) >= 2 ? 2 : 1;
    const TriangleGeometry g = loopSubdivide(padded, faces, 0, "test");
    ASSERT_EQ(g.positions.cols(), 4);
    for (int v = 0; v < 4; ++v) EXPECT_LT((g.positions.col(v) - 0.2f * p.col(v)).norm(), 1e-6f);
}

}  // namespace
}  // namespace alphorn
