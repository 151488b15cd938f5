// Adaptive numerical integration for expected histogram counts: the integral of a density over
// a histogram cell is the probability that a sample lands in it.
#pragma once

#include <functional>

namespace alphorn::stats {

// Adaptive Simpson quadrature of f over [a, b] to absolute tolerance eps. Subdivision stops at
// maxDepth levels (at most 4 * 2^maxDepth panels), which bounds the work near discontinuities
// (a pdf support ending inside a cell) and at peaks the tolerance cannot be met.
double adaptiveSimpson(const std::function<double(double)>& f, double a, double b,
                       double eps = 1e-7, int maxDepth = 12);

// Integral of f(x, y) over [x0, x1] x [y0, y1]: adaptive Simpson in x of adaptive Simpson in y.
double adaptiveSimpson2D(const std::function<double(double, double)>& f, double x0, double y0,
                         double x1, double y1, double eps = 1e-7, int maxDepth = 6);

}  // namespace alphorn::stats
