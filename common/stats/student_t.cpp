#include "common/stats/student_t.h"

#include <absl/strings/str_format.h>
#include <boost/math/distributions/students_t.hpp>

#include <algorithm>
#include <cmath>

namespace alphorn::stats {

double studentTTwoSidedPValue(double t, double dof) {
    if (std::isnan(t) || !(dof > 0.0)) return std::numeric_limits<double>::quiet_NaN();
    if (std::isinf(t)) return 0.0;
    boost::math::students_t dist(dof);
    // The complement keeps tiny tail probabilities accurate (1 - cdf would round to 0).
    return std::min(1.0, 2.0 * boost::math::cdf(boost::math::complement(dist, std::abs(t))));
}

TTestResult studentTTest(double mean, double variance, double reference, uint64_t sampleCount,
                         double alpha) {
    TTestResult r;
    r.mean = mean;
    r.variance = variance;
    r.reference = reference;
    r.sampleCount = sampleCount;
    r.alpha = alpha;
    if (!std::isfinite(mean) || !std::isfinite(variance) || !std::isfinite(reference)) {
        r.t = std::numeric_limits<double>::quiet_NaN();
        r.pValue = 0.0;
        r.passed = false;
        r.message = absl::StrFormat(
            "FAIL: non-finite statistics (mean %g, variance %g, reference %g): the estimator "
            "produced NaN or Inf",
            mean, variance, reference);
        return r;
    }
    if (sampleCount < 2) {
        r.passed = false;
        r.message = absl::StrFormat("FAIL: %d samples are too few for a t-test", sampleCount);
        return r;
    }
    const double n = static_cast<double>(sampleCount);
    r.t = std::abs(mean - reference) * std::sqrt(n / std::max(variance, 1e-5));
    r.pValue = studentTTwoSidedPValue(r.t, n - 1.0);
    r.passed = std::isfinite(r.pValue) && r.pValue >= alpha;
    r.message = absl::StrFormat(
        "%s: mean %.6g (variance %.6g, %d samples), reference %.6g, t = %.4g, p-value = %.4g "
        "%s alpha = %.4g",
        r.passed ? "PASS" : "FAIL", mean, variance, sampleCount, reference, r.t, r.pValue,
        r.passed ? ">=" : "<", alpha);
    return r;
}

MeanVariance meanAndVariance(const double* values, size_t count) {
    MeanVariance out;
    double m2 = 0.0;
    for (size_t k = 0; k < count; ++k) {
        // Knuth/Welford online update (as Nori): stable where sum-of-squares cancels.
        const double delta = values[k] - out.mean;
        out.mean += delta / static_cast<double>(k + 1);
        m2 += delta * (values[k] - out.mean);
    }
    out.variance = count > 1 ? m2 / static_cast<double>(count - 1) : 0.0;
    return out;
}

void RunningStats::merge(const RunningStats& other) {
    if (other.count == 0) return;
    if (count == 0) {
        *this = other;
        return;
    }
    const double n1 = static_cast<double>(count), n2 = static_cast<double>(other.count);
    const double delta = other.mean - mean;
    const double n = n1 + n2;
    mean += delta * (n2 / n);
    m2 += other.m2 + delta * delta * (n1 * n2 / n);
    count += other.count;
}

}  // namespace alphorn::stats
