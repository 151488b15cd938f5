#include "common/scene/quadrics.h"

#include "common/core/error.h"

#include <cmath>

namespace alphorn {

namespace {

// The cells that cut `angle` (radians) into steps of at most kQuadricStepRadians.
int stepsFor(double angle) {
    return std::max(1, static_cast<int>(std::ceil(angle / kQuadricStepRadians - 1e-9)));
}

struct GridVertex {
    Eigen::Vector3d position, normal;
};

// A grid of rows + 1 by columns + 1 vertices, (i, j) at v = i / rows and u = j / columns, made
// by `vertex`(i, j); each cell (i, j)-(i + 1, j + 1) as two triangles wound along +u then +v. A
// collapsed first or last row is a single point (a pole, a disk's centre): its cells keep one
// triangle each.
template <typename VertexFunction>
TriangleGeometry grid(int rows, int columns, bool collapsedFirst, bool collapsedLast,
                      VertexFunction vertex) {
    TriangleGeometry geometry;
    const Eigen::Index count = Eigen::Index(rows + 1) * (columns + 1);
    geometry.positions.resize(3, count);
    geometry.normals.resize(3, count);
    geometry.uvs.resize(2, count);
    for (int i = 0; i <= rows; ++i)
        for (int j = 0; j <= columns; ++j) {
            const GridVertex v = vertex(i, j);
            const Eigen::Index column = Eigen::Index(i) * (columns + 1) + j;
            geometry.positions.col(column) = v.position.cast<float>();
            geometry.normals.col(column) = v.normal.normalized().cast<float>();
            geometry.uvs.col(column) = Point2f(float(double(j) / columns), float(double(i) / rows));
        }
    std::vector<uint32_t> faces;
    auto index = [&](int i, int j) { return uint32_t(i * (columns + 1) + j); };
    for (int i = 0; i < rows; ++i)
        for (int j = 0; j < columns; ++j) {
            const uint32_t a = index(i, j), b = index(i, j + 1), c = index(i + 1, j + 1),
                           d = index(i + 1, j);
            if (!(collapsedFirst && i == 0)) faces.insert(faces.end(), {a, b, c});
            if (!(collapsedLast && i + 1 == rows)) faces.insert(faces.end(), {a, c, d});
        }
    geometry.faces.resize(3, Eigen::Index(faces.size() / 3));
    std::copy(faces.begin(), faces.end(), geometry.faces.data());
    return geometry;
}

void requireFinite(const char* shape, std::initializer_list<std::pair<const char*, float>> values) {
    for (const auto& [name, value] : values)
        if (!std::isfinite(value)) fail("%s: %s must be finite, got %g", shape, name, value);
}

// phimax as pbrt reads it: degrees clamped to [0, 360], in radians; zero is refused.
double phiMaxRadians(const char* shape, float degrees) {
    const double clamped = std::min(360.0, std::max(0.0, double(degrees)));
    if (clamped == 0.0) fail("%s: phimax is %g degrees: the shape has no area", shape, degrees);
    return clamped * M_PI / 180.0;
}

}  // namespace

TriangleGeometry tessellateSphere(float radius, float zmin, float zmax, float phimaxDegrees) {
    requireFinite("sphere",
                  {{"radius", radius}, {"zmin", zmin}, {"zmax", zmax}, {"phimax", phimaxDegrees}});
    if (!(radius > 0.0f)) fail("sphere: the radius must be positive, got %g", radius);
    const double r = radius;
    const double lo = std::max(-r, std::min(r, double(std::min(zmin, zmax))));
    const double hi = std::max(-r, std::min(r, double(std::max(zmin, zmax))));
    if (lo == hi)
        fail("sphere: zmin and zmax (%g, %g) leave no area within the radius %g", zmin, zmax,
             radius);
    const double phiMax = phiMaxRadians("sphere", phimaxDegrees);
    // The polar angle from +z: v = 0 at zmin (the larger angle), 1 at zmax.
    const double thetaLo = std::acos(lo / r), thetaHi = std::acos(hi / r);
    const int rows = stepsFor(thetaLo - thetaHi), columns = stepsFor(phiMax);
    return grid(rows, columns, lo == -r, hi == r, [&](int i, int j) {
        const double theta = i == rows ? thetaHi : thetaLo + (thetaHi - thetaLo) * double(i) / rows;
        const double phi = phiMax * double(j) / columns;
        // Exactly on the axis at a pole, whatever sin(pi) rounds to.
        const double sinTheta = theta == 0.0 || theta == M_PI ? 0.0 : std::sin(theta);
        const Eigen::Vector3d direction(sinTheta * std::cos(phi), sinTheta * std::sin(phi),
                                        std::cos(theta));
        return GridVertex{r * direction, direction};
    });
}

TriangleGeometry tessellateDisk(float height, float radius, float innerRadius,
                                float phimaxDegrees) {
    requireFinite("disk", {{"height", height},
                           {"radius", radius},
                           {"innerradius", innerRadius},
                           {"phimax", phimaxDegrees}});
    if (!(innerRadius >= 0.0f && innerRadius < radius))
        fail("disk: needs 0 <= innerradius < radius, got innerradius %g and radius %g", innerRadius,
             radius);
    const double phiMax = phiMaxRadians("disk", phimaxDegrees);
    const int columns = stepsFor(phiMax);
    // Row 0 the outer rim (v = 0), row 1 the inner one (v = 1): v is linear in the radius, and
    // so is the interpolation across each triangle.
    return grid(1, columns, false, innerRadius == 0.0f, [&](int i, int j) {
        const double rho = i == 0 ? double(radius) : double(innerRadius);
        const double phi = phiMax * double(j) / columns;
        return GridVertex{Eigen::Vector3d(rho * std::cos(phi), rho * std::sin(phi), height),
                          Eigen::Vector3d::UnitZ()};
    });
}

TriangleGeometry tessellateCylinder(float radius, float zmin, float zmax, float phimaxDegrees) {
    requireFinite("cylinder",
                  {{"radius", radius}, {"zmin", zmin}, {"zmax", zmax}, {"phimax", phimaxDegrees}});
    if (!(radius > 0.0f)) fail("cylinder: the radius must be positive, got %g", radius);
    if (zmin == zmax) fail("cylinder: zmin and zmax are both %g: the cylinder has no area", zmin);
    const double lo = std::min(zmin, zmax), hi = std::max(zmin, zmax);
    const double phiMax = phiMaxRadians("cylinder", phimaxDegrees);
    const int columns = stepsFor(phiMax);
    return grid(1, columns, false, false, [&](int i, int j) {
        const double phi = phiMax * double(j) / columns;
        const Eigen::Vector3d outward(std::cos(phi), std::sin(phi), 0.0);
        return GridVertex{
            Eigen::Vector3d(radius * outward.x(), radius * outward.y(), i == 0 ? lo : hi), outward};
    });
}

}  // namespace alphorn
