#include "common/stats/spherical_histogram.h"

#include "common/stats/integrate.h"

#include <tbb/parallel_for.h>

namespace alphorn::stats {

namespace {

Vector3f direction(double cosTheta, double phi) {
    const double sinTheta = std::sqrt(std::max(0.0, 1.0 - cosTheta * cosTheta));
    return Vector3f(static_cast<float>(sinTheta * std::cos(phi)),
                    static_cast<float>(sinTheta * std::sin(phi)), static_cast<float>(cosTheta));
}

double integrateCell(const std::function<double(const Vector3f&)>& pdf, double z0, double z1,
                     double phi0, double phi1) {
    // Simpson's rule evaluates the cell's edges, and a pdf whose support ends exactly on an
    // edge (a hemisphere at cos theta = 0, a cap at its cone) would count its value there for
    // the neighbouring cell too. Evaluating a hair inside the cell keeps each cell to itself;
    // the shift changes smooth integrands by about 1e-7 relative.
    const double zc = 0.5 * (z0 + z1), phic = 0.5 * (phi0 + phi1);
    constexpr double kInset = 1e-7;
    return adaptiveSimpson2D(
        [&](double z, double phi) {
            return pdf(direction(z + (zc - z) * kInset, phi + (phic - phi) * kInset));
        },
        z0, phi0, z1, phi1);
}

}  // namespace

int SphericalGrid::cellOf(const Vector3f& w) const {
    const double z = w.z();
    if (hasRestCell() && (z < cosThetaMin || z > cosThetaMax)) return gridCells();
    const double zScaled = (z - cosThetaMin) / (cosThetaMax - cosThetaMin);
    const int zBin = std::clamp(static_cast<int>(std::floor(zScaled * cosThetaResolution)), 0,
                                cosThetaResolution - 1);
    double scaledPhi =
        std::atan2(static_cast<double>(w.y()), static_cast<double>(w.x())) / (2.0 * M_PI);
    if (scaledPhi < 0.0) scaledPhi += 1.0;
    const int phiBin =
        std::clamp(static_cast<int>(std::floor(scaledPhi * phiResolution)), 0, phiResolution - 1);
    return zBin * phiResolution + phiBin;
}

std::vector<double> expectedFrequencies(const SphericalGrid& grid,
                                        const std::function<double(const Vector3f&)>& pdf,
                                        double sampleCount) {
    std::vector<double> expected(grid.cellCount(), 0.0);
    const double dz = (grid.cosThetaMax - grid.cosThetaMin) / grid.cosThetaResolution;
    const double dphi = 2.0 * M_PI / grid.phiResolution;
    tbb::parallel_for(0, grid.gridCells(), [&](int cell) {
        const int i = cell / grid.phiResolution, j = cell % grid.phiResolution;
        const double z0 = grid.cosThetaMin + i * dz;
        const double z1 = i + 1 == grid.cosThetaResolution ? grid.cosThetaMax : z0 + dz;
        expected[cell] = sampleCount * integrateCell(pdf, z0, z1, j * dphi, (j + 1) * dphi);
    });
    if (grid.hasRestCell()) {
        double rest = 0.0;
        if (grid.cosThetaMin > -1.0)
            rest += integrateCell(pdf, -1.0, grid.cosThetaMin, 0.0, 2.0 * M_PI);
        if (grid.cosThetaMax < 1.0)
            rest += integrateCell(pdf, grid.cosThetaMax, 1.0, 0.0, 2.0 * M_PI);
        expected[grid.gridCells()] = sampleCount * rest;
    }
    return expected;
}

double integrateOverSphere(const std::function<double(const Vector3f&)>& pdf,
                           const SphericalGrid& grid) {
    std::vector<double> cells = expectedFrequencies(grid, pdf, 1.0);
    double sum = 0.0;
    for (double c : cells) sum += c;
    return sum;
}

}  // namespace alphorn::stats
