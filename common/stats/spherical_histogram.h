// Histograms of directions on a (cos theta, phi) grid and their expected counts under a pdf, as
// used by Nori's chi2test. Equal steps in cos theta and phi are equal solid angles, and the
// solid-angle density integrates over (cos theta, phi) without a Jacobian.
#pragma once

#include "common/core/common.h"

#include <functional>

namespace alphorn::stats {

struct SphericalGrid {
    int cosThetaResolution = 10;
    int phiResolution = 20;
    // The grid covers cos theta in [cosThetaMin, cosThetaMax]; directions outside fall into one
    // extra "rest" cell (index cellCount()) when cosThetaMin > -1 or cosThetaMax < 1, so a
    // sharply peaked pdf can be binned finely where its mass is.
    double cosThetaMin = -1.0, cosThetaMax = 1.0;

    bool hasRestCell() const { return cosThetaMin > -1.0 || cosThetaMax < 1.0; }
    int gridCells() const { return cosThetaResolution * phiResolution; }
    int cellCount() const { return gridCells() + (hasRestCell() ? 1 : 0); }
    // Cell of a unit direction (Nori's binning: cos theta from z, phi from atan2(y, x)).
    int cellOf(const Vector3f& w) const;
};

// Expected counts: sampleCount times the integral of pdf over each cell (computed in parallel;
// each cell's value depends only on the cell, so the result is reproducible).
std::vector<double> expectedFrequencies(const SphericalGrid& grid,
                                        const std::function<double(const Vector3f&)>& pdf,
                                        double sampleCount);

// The integral of a solid-angle pdf over the whole sphere (1 for a normalised pdf), summed over
// the cells of `grid` (pass a grid that is fine where the pdf is peaked).
double integrateOverSphere(const std::function<double(const Vector3f&)>& pdf,
                           const SphericalGrid& grid = SphericalGrid());

}  // namespace alphorn::stats
