#include "common/sampler/sampler.h"
#include "common/stats/chi_square.h"
#include "common/stats/sidak.h"
#include "common/stats/student_t.h"
#include "common/texture/plugin_testing.h"

#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <cstring>
#include <functional>
#include <set>

namespace alphorn {
namespace {

using plugin_testing::expectParseError;
using plugin_testing::parseAs;

std::shared_ptr<Sampler> make(const std::string& type, int count = 1) {
    return parseAs<Sampler>(
        "sampler.xml",
        absl::StrFormat(R"(<sampler type="%s"><integer name="sampleCount" value="%d"/></sampler>)",
                        type, count));
}

// One pass of one stream, drawn as the renderer does: 1D, 2D, 1D, 1D, 2D, then 1D draws up to
// dimension 40 and a last 2D draw there (the padding region of a long path).
struct Draws {
    float a = 0;
    Point2f b;
    float c = 0, d = 0;
    Point2f e;
    Point2f far;
};
Draws drawPass(Sampler& s, uint64_t seed, uint64_t pass, uint64_t stream,
               StreamPurpose purpose = StreamPurpose::Camera) {
    s.startStream(seed, pass, stream, purpose);
    Draws out;
    out.a = s.next1D();
    out.b = s.next2D();
    out.c = s.next1D();
    out.d = s.next1D();
    out.e = s.next2D();
    for (int d = 7; d < 40; ++d) s.next1D();
    out.far = s.next2D();
    return out;
}

// A chi-square test that 2D points are uniform on a side x side grid.
stats::Chi2Result uniform2D(const std::vector<Point2f>& points, int side, double alpha) {
    std::vector<double> observed(size_t(side) * side, 0.0);
    for (const Point2f& p : points) {
        EXPECT_GE(p.x(), 0.0f);
        EXPECT_LT(p.x(), 1.0f);
        EXPECT_GE(p.y(), 0.0f);
        EXPECT_LT(p.y(), 1.0f);
        const int x = std::min(int(p.x() * side), side - 1);
        const int y = std::min(int(p.y() * side), side - 1);
        observed[size_t(y) * side + x] += 1;
    }
    const std::vector<double> expected(observed.size(), double(points.size()) / observed.size());
    return stats::chi2Test(observed, expected, double(points.size()), 5, alpha);
}

// Every projection the renderer uses is uniform, and pairs of different draws are independent:
// histograms over 4096 pixels x 16 passes. Within one pixel 16 passes are stratified, so a
// sampler that is too even per pixel still passes; what fails is a bias of the scramble, pixels
// that share points, or draws that repeat or follow each other.
TEST(Sobol, ProjectionsAndPairsOfDrawsAreUniformChiSquare) {
    auto sampler = make("sobol");
    const int streams = 4096, passes = 16;
    std::vector<std::vector<float>> lines(2);
    std::vector<std::vector<Point2f>> sets(7);
    for (int stream = 0; stream < streams; ++stream)
        for (int pass = 0; pass < passes; ++pass) {
            const Draws d = drawPass(*sampler, 42, pass, stream);
            lines[0].push_back(d.a);  // 1D draws
            lines[1].push_back(d.c);
            sets[0].push_back(d.b);  // 2D draws
            sets[1].push_back(d.e);
            sets[2].push_back(d.far);
            sets[3].push_back(Point2f(d.c, d.d));          // consecutive 1D draws
            sets[4].push_back(Point2f(d.a, d.b.x()));      // a 1D draw and the next 2D draw
            sets[5].push_back(Point2f(d.b.x(), d.e.x()));  // two 2D draws
            sets[6].push_back(Point2f(d.b.y(), d.far.y()));
        }
    const double alpha = stats::sidakAlpha(0.01, int(lines.size() + sets.size()) + 2);
    for (const std::vector<float>& line : lines) {
        std::vector<double> observed(64, 0.0);
        for (float v : line) {
            ASSERT_GE(v, 0.0f);
            ASSERT_LT(v, 1.0f);
            observed[int(v * 64)] += 1;
        }
        const stats::Chi2Result r =
            stats::chi2Test(observed, std::vector<double>(64, double(line.size()) / 64),
                            double(line.size()), 5, alpha);
        EXPECT_TRUE(r.passed) << r.message;
    }
    for (size_t i = 0; i < sets.size(); ++i) {
        const stats::Chi2Result r = uniform2D(sets[i], 16, alpha);
        EXPECT_TRUE(r.passed) << "set " << i << ": " << r.message;
    }
    // Photon streams: the same, keyed apart from camera streams.
    std::vector<Point2f> photon, cameraVsPhoton;
    for (int stream = 0; stream < streams; ++stream)
        for (int pass = 0; pass < passes; ++pass) {
            const Draws p = drawPass(*sampler, 42, pass, stream, StreamPurpose::Photon);
            const Draws c = drawPass(*sampler, 42, pass, stream, StreamPurpose::Camera);
            photon.push_back(p.e);
            cameraVsPhoton.push_back(Point2f(p.b.x(), c.b.x()));
        }
    for (const auto& set : {photon, cameraVsPhoton}) {
        const stats::Chi2Result r = uniform2D(set, 16, alpha);
        EXPECT_TRUE(r.passed) << r.message;
    }
}

// Owen scrambling makes two points of a net independent below the digits their position in the
// net fixes. A replicate's (one parity's) samples 2m and 2m + 1, passes 4m + h and 4m + h + 2,
// fall in opposite halves, and within them (frac(2x)) they are independent; its samples 4m + a
// and 4m + a + 2, passes 8m + 2a + h and 8m + 2a + h + 4, are independent in frac(4x)
// (chi-square of the joint histogram over 16384 pixels). Shuffling the index alone, without
// scrambling the values, would keep the other tests' marginals uniform but make these fine
// digits equal. Passes of the two parities belong to independently scrambled replicates, so
// passes 2m and 2m + 1 are independent in every digit (frac(x) = x): the film's halves by pass
// parity are independent estimates, as the error estimate assumes.
TEST(Sobol, PointsOfOneNetAreIndependentBelowTheirSharedDigits) {
    auto sampler = make("sobol");
    const int streams = 16384, side = 16;
    auto frac = [](float v, float scale) { return v * scale - std::floor(v * scale); };
    // Pairs of passes (first, second) and the scale that removes their shared digits.
    const struct {
        int first, second;
        float scale;
    } pairs[] = {{0, 2, 2}, {13, 15, 2}, {0, 4, 4}, {10, 14, 4}, {0, 1, 1}, {6, 7, 1}};
    const double alpha = stats::sidakAlpha(0.01, 6 * 3);
    for (const auto& pair : pairs) {
        std::vector<Point2f> a, bx, by;
        for (int stream = 0; stream < streams; ++stream) {
            const Draws first = drawPass(*sampler, 21, pair.first, stream);
            const Draws second = drawPass(*sampler, 21, pair.second, stream);
            a.push_back(Point2f(frac(first.a, pair.scale), frac(second.a, pair.scale)));
            bx.push_back(Point2f(frac(first.b.x(), pair.scale), frac(second.b.x(), pair.scale)));
            by.push_back(Point2f(frac(first.e.y(), pair.scale), frac(second.e.y(), pair.scale)));
        }
        for (const auto* set : {&a, &bx, &by}) {
            const stats::Chi2Result r = uniform2D(*set, side, alpha);
            EXPECT_TRUE(r.passed) << "passes " << pair.first << ", " << pair.second << ": "
                                  << r.message;
        }
    }
}

bool isNet(const std::vector<Point2f>& points, int log2Count) {
    for (int a = 0; a <= log2Count; ++a) {
        const int nx = 1 << a, ny = 1 << (log2Count - a);
        std::set<std::pair<int, int>> cells;
        for (const Point2f& p : points) cells.insert({int(p.x() * nx), int(p.y() * ny)});
        if (int(cells.size()) != (1 << log2Count)) return false;
    }
    return true;
}

// The first 2^k samples of a replicate's 2D draw (its passes: those of one parity) are a
// (0,k,2)-net: one point in every cell of every 2^a x 2^(k-a) grid; so are later aligned blocks of
// 2^k of its samples (samples 3 * 2^k ..). A 1D draw puts one point in each of 2^k strata.
TEST(Sobol, AlignedBlocksOfPowerOfTwoPassesOfOneParityAreZeroTwoNets) {
    auto sampler = make("sobol");
    for (uint64_t stream : {0ull, 1ull, 987654321ull})
        for (uint64_t replicate : {0ull, 1ull})
            for (int k = 0; k <= 10; ++k)
                for (uint64_t block : {0ull, 3ull}) {
                    const uint64_t n = uint64_t(1) << k;
                    std::vector<Point2f> b, e, far;
                    std::set<int> strataA, strataD;
                    for (uint64_t sample = block * n; sample < (block + 1) * n; ++sample) {
                        const Draws d = drawPass(*sampler, 7, 2 * sample + replicate, stream);
                        b.push_back(d.b);
                        e.push_back(d.e);
                        far.push_back(d.far);
                        strataA.insert(int(d.a * n));
                        strataD.insert(int(d.d * n));
                    }
                    const std::string where = "k " + std::to_string(k) + " stream " +
                                              std::to_string(stream) + " replicate " +
                                              std::to_string(replicate);
                    EXPECT_TRUE(isNet(b, k)) << where;
                    EXPECT_TRUE(isNet(e, k)) << where;
                    EXPECT_TRUE(isNet(far, k)) << where;
                    EXPECT_EQ(strataA.size(), n) << where;
                    EXPECT_EQ(strataD.size(), n) << where;
                }
}

// Same (seed, pass, stream, dimension), same number: alone, in another order, in a clone, on
// other threads. And other seeds and streams give other numbers.
TEST(Sobol, IsAPureFunctionOfSeedPassStreamAndDimension) {
    auto sampler = make("sobol");
    const int streams = 64, passes = 64;
    std::vector<Draws> sequential;
    for (int stream = 0; stream < streams; ++stream)
        for (int pass = 0; pass < passes; ++pass)
            sequential.push_back(drawPass(*sampler, 5, pass, stream));
    std::vector<Draws> parallel(sequential.size());
    tbb::parallel_for(0, streams * passes, [&](int i) {
        const int j = streams * passes - 1 - i;  // backwards, one clone per task
        auto clone = sampler->clone();
        parallel[j] = drawPass(*clone, 5, j % passes, j / passes);
    });
    for (size_t i = 0; i < sequential.size(); ++i) {
        EXPECT_EQ(sequential[i].a, parallel[i].a);
        EXPECT_EQ(sequential[i].b, parallel[i].b);
        EXPECT_EQ(sequential[i].e, parallel[i].e);
        EXPECT_EQ(sequential[i].far, parallel[i].far);
    }
    int same = 0;
    for (int pass = 0; pass < passes; ++pass) {
        const Draws base = drawPass(*sampler, 5, pass, 3);
        same += base.a == drawPass(*sampler, 6, pass, 3).a;
        same += base.a == drawPass(*sampler, 5, pass, 4).a;
        same += base.a == drawPass(*sampler, 5, pass, 3, StreamPurpose::Photon).a;
        same += base.a == drawPass(*sampler, 5, pass + (uint64_t(1) << 33), 3).a;
    }
    EXPECT_EQ(same, 0);
}

// The numbers themselves are pinned: every sobol image's bytes depend on them, so a change meant
// only to make the sampler faster must leave this checksum of 64 streams x 16 passes of draws
// (drawPass's 1D and 2D mix, and draws at dimension 40) as it is. A deliberate change of the
// numbers updates the constant and says so (last: passes split into two replicates by parity).
TEST(Sobol, DrawsArePinnedByAChecksum) {
    auto sampler = make("sobol");
    uint64_t checksum = 0xcbf29ce484222325ULL;
    const auto add = [&](float x) {
        uint32_t bits;
        std::memcpy(&bits, &x, sizeof(bits));
        checksum = (checksum ^ bits) * 0x100000001b3ULL;
    };
    for (int stream = 0; stream < 64; ++stream)
        for (int pass = 0; pass < 16; ++pass) {
            const Draws d = drawPass(*sampler, 11, pass, stream);
            add(d.a), add(d.b.x()), add(d.b.y()), add(d.c), add(d.d), add(d.e.x()), add(d.e.y());
            add(d.far.x()), add(d.far.y());
        }
    EXPECT_EQ(checksum, 0x538d79cf9a4afda8ULL);
}

// The estimate of an integral from 16 passes of a pixel is unbiased (t-test over independent
// pixels), including a product over 12 dimensions whose mean is 1 only if the draws of a pass
// are independent of each other.
TEST(Sobol, EstimatesAreUnbiasedTTest) {
    auto sampler = make("sobol");
    const double alpha = stats::sidakAlpha(0.01, 3);
    struct Integrand {
        std::function<double(Sampler&)> f;
        double exact;
    };
    const Integrand integrands[] = {
        // A disc of radius 0.4 (an edge), 2D.
        {[](Sampler& s) {
             const Point2f p = s.next2D();
             return (p - Point2f(0.5f, 0.5f)).squaredNorm() < 0.16f ? 1.0 : 0.0;
         },
         Pi * 0.16},
        {[](Sampler& s) { return std::exp(double(s.next1D())); }, std::exp(1.0) - 1.0},
        {[](Sampler& s) {
             double product = 1;
             for (int i = 0; i < 4; ++i) product *= 2.0 * s.next1D();
             for (int i = 0; i < 4; ++i) {
                 const Point2f p = s.next2D();
                 product *= 4.0 * p.x() * p.y();
             }
             return product;
         },
         1.0},
    };
    for (const Integrand& integrand : integrands) {
        const int streams = 20000, passes = 16;
        stats::RunningStats estimates;
        for (int stream = 0; stream < streams; ++stream) {
            double estimate = 0;
            for (int pass = 0; pass < passes; ++pass) {
                sampler->startStream(11, pass, stream, StreamPurpose::Camera);
                sampler->next2D();  // the pixel position, as the renderer draws it
                estimate += integrand.f(*sampler) / passes;
            }
            estimates.add(estimate);
        }
        const stats::TTestResult r = stats::studentTTest(estimates.mean, estimates.variance(),
                                                         integrand.exact, estimates.count, alpha);
        EXPECT_TRUE(r.passed) << r.message;
    }
}

// Scrambled nets converge faster than independent points on a smooth integrand: at 64 passes the
// variance of a smooth 2D integral's estimate is below a hundredth of independent sampling's
// (theory: O(n^-3) against O(n^-1)).
TEST(Sobol, LowerVarianceThanIndependentOnASmoothIntegrand) {
    auto f = [](const Point2f& p) {
        return std::exp(p.x()) * std::sin(Pi * p.y()) + p.x() * p.y();
    };
    auto variance = [&](Sampler& s) {
        stats::RunningStats estimates;
        const int n = 64;
        for (int stream = 0; stream < 400; ++stream) {
            double estimate = 0;
            for (int p = 0; p < n; ++p) {
                s.startStream(1, p, stream, StreamPurpose::Camera);
                s.next2D();
                estimate += f(s.next2D()) / n;
            }
            estimates.add(estimate);
        }
        return estimates.variance();
    };
    const double sobol = variance(*make("sobol"));
    const double independent = variance(*make("independent"));
    EXPECT_LT(sobol, 0.01 * independent) << sobol << " vs " << independent;
}

TEST(Sobol, ClearErrors) {
    expectParseError("sobol_bad.xml", R"(<sampler type="sobol">
  <integer name="sampleCount" value="0"/>
</sampler>)",
                     1, "sampleCount");
}

}  // namespace
}  // namespace alphorn
