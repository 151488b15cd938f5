// The radius schedule against two independent references: the Knaus–Zwicker recurrence
// r²(N + 1) = r²(N)(N + α)/(N + 1) multiplied out in long double (64-bit mantissa, so 10⁷
// factors drift by at most ~10⁻¹², far below the 10⁻⁹ asked for), and the closed form for
// α = 1/2, r²(N)/r²(1) = Γ(N + 1/2) / (Γ(3/2) N!), evaluated independently to 9 digits.
#include "common/photon/radius_schedule.h"

#include <gtest/gtest.h>

namespace alphorn {
namespace {

// Checks every N in [1, 1000] and then every 997th N up to 10⁷ (plus 10⁷ itself).
void expectMatchesRecurrence(double alpha) {
    long double ratio = 1.0L;
    double worst = 0.0;
    uint64_t worstN = 0;
    constexpr uint64_t kLast = 10'000'000;
    for (uint64_t n = 1; n <= kLast; ++n) {
        if (n > 1) ratio *= (static_cast<long double>(n - 1) + alpha) / static_cast<long double>(n);
        if (n <= 1000 || n % 997 == 0 || n == kLast) {
            const double got = progressiveRadiusSquaredRatio(n, alpha);
            const double error = std::abs(static_cast<double>((got - ratio) / ratio));
            if (!(error <= worst)) worst = error, worstN = n;  // also catches NaN
        }
    }
    EXPECT_LT(worst, 1e-9) << "alpha " << alpha << ": worst relative error at N = " << worstN;
}

TEST(RadiusSchedule, MatchesTheRecurrenceUpToTenMillionPasses) {
    expectMatchesRecurrence(0.5);
    expectMatchesRecurrence(0.8);
    expectMatchesRecurrence(0.1);
}

TEST(RadiusSchedule, MatchesTheClosedFormForAlphaOneHalf) {
    // Γ(N + 1/2) / (Γ(3/2) N!) to 9 significant digits, so compare to half a unit of the last
    // digit.
    EXPECT_NEAR(progressiveRadiusSquaredRatio(10, 0.5), 0.352394104, 5e-10);
    EXPECT_NEAR(progressiveRadiusSquaredRatio(1000, 0.5), 0.0356780223, 5e-11);
    EXPECT_NEAR(progressiveRadiusSquaredRatio(1'000'000, 0.5), 0.00112837903, 5e-12);
}

TEST(RadiusSchedule, PassZeroUsesTheInitialRadiusAndLaterPassesShrink) {
    EXPECT_EQ(progressiveRadius(0.25, 0.5, 0), 0.25);
    // Pass index 1 is N = 2: r² shrinks by (1 + α)/2.
    EXPECT_DOUBLE_EQ(progressiveRadius(2.0, 0.5, 1), 2.0 * std::sqrt(0.75));
    double previous = progressiveRadius(1.0, 0.5, 0);
    for (uint64_t pass = 1; pass < 5000; pass += 7) {
        const double r = progressiveRadius(1.0, 0.5, pass);
        EXPECT_LT(r, previous) << pass;
        previous = r;
    }
    // Far beyond 32-bit pass counts the radius is still positive and finite.
    const double far = progressiveRadius(1.0, 0.5, uint64_t(1) << 40);
    EXPECT_GT(far, 0.0);
    EXPECT_TRUE(std::isfinite(far));
}

TEST(RadiusSchedule, RejectsInvalidArguments) {
    EXPECT_THROW(progressiveRadiusSquaredRatio(0, 0.5), std::invalid_argument);
    for (double alpha : {0.0, 1.0, -0.5, 1.5, std::nan("")})
        EXPECT_THROW(progressiveRadiusSquaredRatio(3, alpha), std::invalid_argument) << alpha;
}

}  // namespace
}  // namespace alphorn
