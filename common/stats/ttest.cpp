// <test type="ttest">: Student's t-test of Monte Carlo means against reference values (Nori's
// StudentsTTest, same property names and defaults). Children are either scenes -- the mean
// luminance seen through the camera at uniformly random image positions -- or BSDFs -- the mean
// sampling weight eval * cos / pdf for an incident direction at the listed `angles` in degrees,
// i.e. the directional albedo.
#include "common/bsdf/bsdf.h"
#include "common/scene/scene.h"
#include "common/stats/sidak.h"
#include "common/stats/student_t.h"
#include "common/stats/test_object.h"

#include <absl/strings/str_format.h>
#include <tbb/parallel_for.h>

#include <ostream>

namespace alphorn {

namespace {
// Fixed so that a test file always draws the same samples: a pass stays a pass.
constexpr uint64_t kTestSeed = 0x7e57'5eedULL;
// Samples per accumulator chunk (and parallel task).
constexpr size_t kGrain = 1024;

double luminance(const Color3f& c) {
    return 0.212671 * double(c.r()) + 0.715160 * double(c.g()) + 0.072169 * double(c.b());
}
}  // namespace

class StudentsTTest : public StatisticalTest {
  public:
    explicit StudentsTTest(const PropertyList& props) {
        // The null hypothesis (mean == reference) is rejected when the p-value is below this.
        m_significanceLevel = props.getFloat("significanceLevel", 0.01f);
        if (!(m_significanceLevel > 0.0f && m_significanceLevel < 1.0f))
            props.fail("significanceLevel must be in (0, 1), got %g", m_significanceLevel);
        m_angles = parseFloatList(props, "angles");
        m_references = parseFloatList(props, "references");
        m_sampleCount = props.getInteger("sampleCount", 100000);
        if (m_sampleCount < 2) props.fail("sampleCount must be at least 2, got %d", m_sampleCount);
        PropertyList samplerProps(props.source() + " (test sampler)");
        m_sampler = std::static_pointer_cast<Sampler>(
            ObjectFactory::create(ObjectKind::Sampler, "independent", samplerProps));
        m_sampler->activate();
    }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        switch (child->kind()) {
            case ObjectKind::BSDF:
                m_bsdfs.push_back(std::static_pointer_cast<BSDF>(child));
                break;
            case ObjectKind::Scene:
                m_scenes.push_back(std::static_pointer_cast<Scene>(child));
                break;
            default:
                Object::addChild(child, name);
        }
    }

    void activate() override {
        if (!m_bsdfs.empty() && !m_scenes.empty())
            fail("cannot test BSDFs and scenes in the same <test>");
        if (m_references.empty()) fail("no \"references\" given");
        if (!m_scenes.empty()) {
            if (m_references.size() != m_scenes.size())
                fail("%zu references for %zu scenes: give one reference per scene",
                     m_references.size(), m_scenes.size());
            if (!m_angles.empty()) fail("\"angles\" applies to BSDFs only, not to scenes");
            for (const auto& scene : m_scenes)
                if (scene->camera()->outputSize().minCoeff() <= 0)
                    scene->fail("the camera has an empty image");
        } else if (!m_bsdfs.empty()) {
            // angles and references are parallel lists, one entry per test case; the BSDF
            // children take equal consecutive shares of them (Nori: one BSDF, every angle;
            // one angle per BSDF also works).
            if (m_angles.size() != m_references.size())
                fail("%zu angles but %zu references: give one reference per angle", m_angles.size(),
                     m_references.size());
            if (m_references.size() % m_bsdfs.size() != 0)
                fail("%zu references cannot be split evenly among %zu BSDFs", m_references.size(),
                     m_bsdfs.size());
        } else {
            fail("nothing to test: add <scene> or <bsdf> children");
        }
    }

    Summary run(std::ostream& out) const override {
        Summary summary;
        const int m = static_cast<int>(m_references.size());
        // Šidák over all references of this file, as Nori does.
        const double alpha = stats::sidakAlpha(m_significanceLevel, m);
        const size_t perBsdf = m_bsdfs.empty() ? 0 : m_references.size() / m_bsdfs.size();
        for (int i = 0; i < m; ++i) {
            // One accumulator per chunk of kGrain samples, merged in chunk order below.
            std::vector<stats::RunningStats> chunks((m_sampleCount + kGrain - 1) / kGrain);
            std::string what;
            if (!m_scenes.empty()) {
                const Scene& scene = *m_scenes[i];
                what = absl::StrFormat("scene %s", scene.source());
                sampleScene(scene, static_cast<uint64_t>(i), chunks);
            } else {
                const BSDF& bsdf = *m_bsdfs[i / perBsdf];
                const float angle = m_angles[i];
                what =
                    absl::StrFormat("%s at %g degrees (%s)", bsdf.toString(), angle, bsdf.source());
                sampleBSDF(bsdf, angle, static_cast<uint64_t>(i), chunks);
            }
            stats::RunningStats total;
            for (const stats::RunningStats& chunk : chunks) total.merge(chunk);
            const stats::TTestResult result = stats::studentTTest(
                total.mean, total.variance(), m_references[i], total.count, alpha);
            ++summary.total;
            if (result.passed) ++summary.passed;
            out << absl::StrFormat("ttest %d/%d: %s\n  %s\n", i + 1, m, what, result.message);
        }
        out << absl::StrFormat("ttest %s: passed %d/%d\n", source(), summary.passed, summary.total);
        return summary;
    }

    std::string toString() const override {
        return absl::StrFormat("ttest (significanceLevel %g, sampleCount %d)", m_significanceLevel,
                               m_sampleCount);
    }

  private:
    // Runs sampleOnce(sampler) for samples [0, m_sampleCount): sample k draws from its own
    // stream (seed, test case, k), and chunk c accumulates samples [c * kGrain, (c + 1) * kGrain),
    // so neither the thread count nor the scheduling can change a single bit.
    template <typename SampleOnce>
    void sampleChunks(uint64_t testCase, std::vector<stats::RunningStats>& chunks,
                      SampleOnce&& sampleOnce) const {
        tbb::parallel_for(size_t{0}, chunks.size(), [&](size_t c) {
            std::unique_ptr<Sampler> sampler = m_sampler->clone();
            const size_t end = std::min(static_cast<size_t>(m_sampleCount), (c + 1) * kGrain);
            stats::RunningStats acc;
            for (size_t k = c * kGrain; k < end; ++k) {
                sampler->startStream(kTestSeed, testCase, k, StreamPurpose::Test);
                acc.add(luminance(sampleOnce(*sampler)));
            }
            chunks[c] = acc;
        });
    }

    // Nori's scene mode: a uniform image position, a camera ray, the integrator's estimate.
    void sampleScene(const Scene& scene, uint64_t testCase,
                     std::vector<stats::RunningStats>& chunks) const {
        const Camera& camera = *scene.camera();
        const Integrator& integrator = *scene.integrator();
        const std::shared_ptr<const PassData> pass =
            integrator.preparePass(scene, kTestSeed, testCase);
        const Vector2f size = camera.outputSize().cast<float>();
        sampleChunks(testCase, chunks, [&](Sampler& sampler) {
            const Point2f position = sampler.next2D().cwiseProduct(size);
            const Point2f aperture = sampler.next2D();
            Ray3f ray;
            Color3f value = camera.sampleRay(ray, position, aperture);
            if (!value.isBlack()) value *= integrator.Li(scene, sampler, ray, pass.get());
            return value;
        });
    }

    // Nori's BSDF mode: wi at `angle` from the normal (phi = 0); the sampling weight.
    void sampleBSDF(const BSDF& bsdf, float angle, uint64_t testCase,
                    std::vector<stats::RunningStats>& chunks) const {
        const Vector3f wi = sphericalDirection(degToRad(angle), 0.0f);
        sampleChunks(testCase, chunks, [&](Sampler& sampler) {
            BSDFQueryRecord rec(wi);
            return bsdf.sample(rec, sampler.next2D());
        });
    }

    float m_significanceLevel;
    int m_sampleCount;
    std::vector<float> m_angles, m_references;
    std::vector<std::shared_ptr<BSDF>> m_bsdfs;
    std::vector<std::shared_ptr<Scene>> m_scenes;
    std::shared_ptr<Sampler> m_sampler;
};

ALPHORN_REGISTER(Test, "ttest", StudentsTTest);

}  // namespace alphorn
