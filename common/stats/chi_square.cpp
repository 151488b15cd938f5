#include "common/stats/chi_square.h"

#include "common/core/error.h"

#include <absl/strings/str_format.h>
#include <boost/math/distributions/chi_squared.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace alphorn::stats {

double chiSquareUpperTail(double statistic, double dof) {
    if (std::isnan(statistic) || !(dof > 0.0)) return std::numeric_limits<double>::quiet_NaN();
    if (std::isinf(statistic)) return 0.0;
    if (statistic <= 0.0) return 1.0;
    boost::math::chi_squared dist(dof);
    // The complement keeps tiny tail probabilities accurate (1 - cdf would round to 0).
    return boost::math::cdf(boost::math::complement(dist, statistic));
}

Chi2Result chi2Test(const std::vector<double>& observed, const std::vector<double>& expected,
                    double sampleCount, double minExpFrequency, double alpha) {
    if (observed.size() != expected.size())
        fail("chi2Test: %zu observed cells but %zu expected", observed.size(), expected.size());
    Chi2Result r;
    r.alpha = alpha;
    auto reject = [&](std::string why) {
        r.passed = false;
        r.pValue = 0.0;
        r.message = "FAIL: " + why;
        return r;
    };
    for (size_t i = 0; i < expected.size(); ++i)
        if (!std::isfinite(expected[i]) || expected[i] < 0.0 || !std::isfinite(observed[i]))
            return reject(
                absl::StrFormat("cell %zu has a non-finite or negative count "
                                "(observed %g, expected %g)",
                                i, observed[i], expected[i]));

    std::vector<size_t> order(expected.size());
    std::iota(order.begin(), order.end(), size_t{0});
    // stable_sort: ties keep their cell order, so the pooling is reproducible.
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return expected[a] < expected[b]; });

    double pooledObserved = 0.0, pooledExpected = 0.0, chi2 = 0.0;
    int dof = 0;
    for (size_t i : order) {
        if (expected[i] == 0.0) {
            // Allow a hair of slack: rounding at cell borders can put a sample next door.
            if (observed[i] > sampleCount * 1e-5)
                return reject(absl::StrFormat(
                    "%g samples fell in cell %zu where the pdf integrates to 0", observed[i], i));
        } else if (expected[i] < minExpFrequency ||
                   (pooledExpected > 0.0 && pooledExpected < minExpFrequency)) {
            pooledObserved += observed[i];
            pooledExpected += expected[i];
            ++r.pooledCells;
        } else {
            const double diff = observed[i] - expected[i];
            chi2 += diff * diff / expected[i];
            ++dof;
        }
    }
    if (pooledExpected > 0.0 || pooledObserved > 0.0) {
        const double diff = pooledObserved - pooledExpected;
        chi2 += diff * diff / pooledExpected;
        ++dof;
    }
    // All parameters of the null distribution are known: only the total is constrained.
    dof -= 1;
    r.statistic = chi2;
    r.dof = dof;
    if (dof <= 0)
        return reject(
            absl::StrFormat("%d degrees of freedom are too few (make cells smaller or "
                            "take more samples)",
                            dof));
    r.pValue = chiSquareUpperTail(chi2, dof);
    r.passed = std::isfinite(r.pValue) && r.pValue >= alpha;
    r.message = absl::StrFormat(
        "%s: chi^2 = %.4g with %d degrees of freedom (%d cells pooled), "
        "p-value = %.4g %s alpha = %.4g",
        r.passed ? "PASS" : "FAIL", chi2, dof, r.pooledCells, r.pValue, r.passed ? ">=" : "<",
        alpha);
    return r;
}

}  // namespace alphorn::stats
