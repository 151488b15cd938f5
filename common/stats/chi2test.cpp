// <test type="chi2test">: Pearson's chi-square test that a BSDF's sample() draws directions
// with the density its pdf() claims (Nori's ChiSquareTest, same property names and defaults).
// <phase> children (media phase functions) are tested the same way, over the whole sphere.
// Directions are binned on a (cos theta, phi) grid and compared with the pdf integrated over
// each cell. Samples of weight zero are dropped, so the pdf must integrate to the probability
// that sampling succeeds.
#include "common/bsdf/bsdf.h"
#include "common/core/rng.h"
#include "common/phase/phase.h"
#include "common/stats/chi_square.h"
#include "common/stats/sidak.h"
#include "common/stats/spherical_histogram.h"
#include "common/stats/test_object.h"

#include <absl/strings/str_format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <functional>
#include <mutex>
#include <ostream>

namespace alphorn {

namespace {
constexpr uint64_t kTestSeed = 0xc412'5eedULL;
// Samples per random stream / parallel task. Counts are integers, so the order in which tasks
// add them up cannot change the histogram.
constexpr int64_t kChunk = 1 << 16;
}  // namespace

class ChiSquareTest : public StatisticalTest {
  public:
    explicit ChiSquareTest(const PropertyList& props) {
        m_significanceLevel = props.getFloat("significanceLevel", 0.01f);
        if (!(m_significanceLevel > 0.0f && m_significanceLevel < 1.0f))
            props.fail("significanceLevel must be in (0, 1), got %g", m_significanceLevel);
        // Cells along cos theta; phi gets twice as many.
        m_grid.cosThetaResolution = props.getPositiveInteger("resolution", 10);
        if (m_grid.cosThetaResolution > 1000)
            props.fail("resolution %d is too large (at most 1000)", m_grid.cosThetaResolution);
        m_grid.phiResolution = 2 * m_grid.cosThetaResolution;
        // The chi-square approximation needs expected counts of about 5 or more; smaller cells
        // are pooled.
        m_minExpFrequency = props.getInteger("minExpFrequency", 5);
        if (m_minExpFrequency < 0)
            props.fail("minExpFrequency must not be negative, got %d", m_minExpFrequency);
        // -1 (Nori's default): about 5000 samples per cell, 1M for the default grid.
        m_sampleCount = props.getInteger("sampleCount", -1);
        if (m_sampleCount < 0 && m_sampleCount != -1)
            props.fail("sampleCount must be positive (or -1 for automatic), got %d", m_sampleCount);
        if (m_sampleCount == -1) m_sampleCount = m_grid.gridCells() * 5000;
        if (m_sampleCount == 0) props.fail("sampleCount must be positive");
        // Random incident directions tested per BSDF.
        m_testCount = props.getPositiveInteger("testCount", 5);
    }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        if (child->kind() == ObjectKind::BSDF)
            m_bsdfs.push_back(std::static_pointer_cast<BSDF>(child));
        else if (child->kind() == ObjectKind::PhaseFunction)
            m_phases.push_back(std::static_pointer_cast<PhaseFunction>(child));
        else
            Object::addChild(child, name);
    }

    void activate() override {
        if (m_bsdfs.empty() && m_phases.empty())
            fail("nothing to test: add <bsdf> or <phase> children");
    }

    Summary run(std::ostream& out) const override {
        // Each tested object as a sampler of wo and its density, for one incident direction.
        struct Target {
            std::string name, source;
            std::function<Vector3f(const Vector3f&, const Point2f&, bool&)> sample;
            std::function<double(const Vector3f&, const Vector3f&)> pdf;
        };
        std::vector<Target> targets;
        for (const auto& bsdf : m_bsdfs)
            targets.push_back(
                Target{bsdf->toString(), bsdf->source(),
                       [bsdf](const Vector3f& wi, const Point2f& u, bool& valid) {
                           BSDFQueryRecord rec(wi);
                           const Color3f weight = bsdf->sample(rec, u);
                           valid = !weight.isBlack();  // failed samples are not in the distribution
                           if (valid && !weight.allFinite()) rec.wo = Vector3f::Constant(NAN);
                           return rec.wo;
                       },
                       [bsdf](const Vector3f& wi, const Vector3f& wo) {
                           return double(bsdf->pdf(BSDFQueryRecord(wi, wo, Measure::SolidAngle)));
                       }});
        for (const auto& phase : m_phases)
            targets.push_back(Target{phase->toString(), phase->source(),
                                     [phase](const Vector3f& wi, const Point2f& u, bool& valid) {
                                         Vector3f wo;
                                         const float weight = phase->sample(wi, wo, u);
                                         valid = weight != 0.0f;
                                         if (valid && !std::isfinite(weight))
                                             wo = Vector3f::Constant(NAN);
                                         return wo;
                                     },
                                     [phase](const Vector3f& wi, const Vector3f& wo) {
                                         return double(phase->pdf(wi, wo));
                                     }});

        Summary summary;
        const int m = m_testCount * static_cast<int>(targets.size());
        const double alpha = stats::sidakAlpha(m_significanceLevel, m);
        int index = 0;
        for (const Target& target : targets) {
            for (int l = 0; l < m_testCount; ++l, ++index) {
                // A random direction in the upper hemisphere (Nori: uniform in cos theta).
                Rng rng(kTestSeed, static_cast<uint64_t>(index), 0, StreamPurpose::Test);
                const float cosTheta = rng.nextFloat();
                const float sinTheta = safeSqrt(1.0f - cosTheta * cosTheta);
                const float phi = 2.0f * Pi * rng.nextFloat();
                const Vector3f wi(std::cos(phi) * sinTheta, std::sin(phi) * sinTheta, cosTheta);

                uint64_t invalid = 0;
                const std::vector<double> observed = histogram(target.sample, wi, index, invalid);
                const std::vector<double> expected = stats::expectedFrequencies(
                    m_grid, [&](const Vector3f& wo) { return target.pdf(wi, wo); }, m_sampleCount);
                stats::Chi2Result result =
                    stats::chi2Test(observed, expected, m_sampleCount, m_minExpFrequency, alpha);
                if (invalid > 0) {
                    result.passed = false;
                    result.message = absl::StrFormat(
                        "FAIL: %d samples had non-finite weight or direction", invalid);
                }
                ++summary.total;
                if (result.passed) ++summary.passed;
                out << absl::StrFormat(
                    "chi2test %d/%d: %s (%s), wi = (%.4f, %.4f, %.4f), %d samples on %dx%d cells\n"
                    "  %s\n",
                    index + 1, m, target.name, target.source, wi.x(), wi.y(), wi.z(), m_sampleCount,
                    m_grid.cosThetaResolution, m_grid.phiResolution, result.message);
            }
        }
        out << absl::StrFormat("chi2test %s: passed %d/%d\n", source(), summary.passed,
                               summary.total);
        return summary;
    }

    std::string toString() const override {
        return absl::StrFormat("chi2test (%dx%d cells, %d samples, %d directions)",
                               m_grid.cosThetaResolution, m_grid.phiResolution, m_sampleCount,
                               m_testCount);
    }

  private:
    std::vector<double> histogram(
        const std::function<Vector3f(const Vector3f&, const Point2f&, bool&)>& sample,
        const Vector3f& wi, int testIndex, uint64_t& invalid) const {
        std::vector<double> counts(m_grid.cellCount(), 0.0);
        std::mutex mutex;
        const int chunks = static_cast<int>((int64_t{m_sampleCount} + kChunk - 1) / kChunk);
        tbb::parallel_for(0, chunks, [&](int chunk) {
            std::vector<uint64_t> local(counts.size(), 0);
            uint64_t localInvalid = 0;
            Rng rng(kTestSeed, static_cast<uint64_t>(testIndex), 1 + static_cast<uint64_t>(chunk),
                    StreamPurpose::Test);
            const int64_t end = std::min<int64_t>(m_sampleCount, (chunk + 1) * kChunk);
            for (int64_t i = chunk * kChunk; i < end; ++i) {
                const float u = rng.nextFloat();
                const Point2f point(u, rng.nextFloat());
                bool valid = false;
                const Vector3f wo = sample(wi, point, valid);
                if (!valid) continue;  // failed sample: not part of the distribution
                if (!wo.allFinite()) {
                    ++localInvalid;
                    continue;
                }
                ++local[m_grid.cellOf(wo)];
            }
            std::lock_guard lock(mutex);
            for (size_t c = 0; c < local.size(); ++c) counts[c] += static_cast<double>(local[c]);
            invalid += localInvalid;
        });
        return counts;
    }

    float m_significanceLevel;
    stats::SphericalGrid m_grid;
    int m_minExpFrequency;
    int m_sampleCount;
    int m_testCount;
    std::vector<std::shared_ptr<BSDF>> m_bsdfs;
    std::vector<std::shared_ptr<PhaseFunction>> m_phases;
};

ALPHORN_REGISTER(Test, "chi2test", ChiSquareTest);

}  // namespace alphorn
