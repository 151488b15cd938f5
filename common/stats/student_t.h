// Student's t-test for the equality of a Monte Carlo mean with a known value (Nori's
// hypothesis::students_t_test), with the hole that lets NaN pass closed.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>

namespace alphorn::stats {

// Two-sided p-value of a t statistic with `dof` degrees of freedom: P(|T| >= |t|).
double studentTTwoSidedPValue(double t, double dof);

struct TTestResult {
    double mean = 0.0, variance = 0.0, reference = 0.0;
    uint64_t sampleCount = 0;
    double t = 0.0;       // |mean - reference| * sqrt(N / max(variance, 1e-5))
    double pValue = 0.0;  // two-sided, N - 1 degrees of freedom
    double alpha = 0.0;   // the (corrected) significance level it was compared with
    bool passed = false;
    std::string message;  // one line: PASS/FAIL with the numbers
};

// Compares a sample mean and (unbiased) sample variance of N samples with `reference` at the
// already corrected significance level `alpha`. A non-finite mean, variance or reference fails:
// NaN would otherwise compare false with everything and pass (Nori's known flaw).
TTestResult studentTTest(double mean, double variance, double reference, uint64_t sampleCount,
                         double alpha);

// Mean and unbiased variance of values, accumulated in a fixed order (Welford), so the same
// values always give the same bits.
struct MeanVariance {
    double mean = 0.0, variance = 0.0;
};
MeanVariance meanAndVariance(const double* values, size_t count);

// Welford's running mean and sum of squared deviations. Accumulators of consecutive chunks
// merge exactly in the chunk order (Chan et al.), so a parallel run that merges its chunks in
// a fixed order gives the same bits for any number of threads, in O(chunks) memory.
struct RunningStats {
    uint64_t count = 0;
    double mean = 0.0, m2 = 0.0;

    void add(double x) {
        ++count;
        const double delta = x - mean;
        mean += delta / static_cast<double>(count);
        m2 += delta * (x - mean);
    }
    void merge(const RunningStats& other);
    double variance() const { return count > 1 ? m2 / static_cast<double>(count - 1) : 0.0; }
    // Standard error of the mean.
    double standardError() const {
        return count > 1 ? std::sqrt(variance() / static_cast<double>(count)) : 0.0;
    }
};

}  // namespace alphorn::stats
