// Pearson's chi-square goodness-of-fit test of a histogram against expected cell counts (Nori's
// hypothesis::chi2_test): cells whose expected count is below a minimum are pooled, because the
// chi-square approximation of the statistic breaks down for small expected counts.
#pragma once

#include <string>
#include <vector>

namespace alphorn::stats {

// P(X >= statistic) for X ~ chi-square with `dof` degrees of freedom.
double chiSquareUpperTail(double statistic, double dof);

struct Chi2Result {
    double statistic = 0.0;
    int dof = 0;
    double pValue = 0.0;
    int pooledCells = 0;
    double alpha = 0.0;  // the (corrected) significance level it was compared with
    bool passed = false;
    std::string message;  // PASS/FAIL with the numbers, or why the test could not be run
};

// observed[i] and expected[i] are counts for cell i; sampleCount is the number of samples drawn
// (used to judge a stray sample in a cell that should be empty). Cells with expected count below
// minExpFrequency are pooled in increasing order of expected count until the pool reaches it.
// `alpha` is the already corrected significance level.
Chi2Result chi2Test(const std::vector<double>& observed, const std::vector<double>& expected,
                    double sampleCount, double minExpFrequency, double alpha);

}  // namespace alphorn::stats
