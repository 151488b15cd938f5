// <test type="ttest">: Student's t-test of Monte Carlo means against reference values (Nori's
// StudentsTTest, same property names and defaults). Children are either scenes -- the mean
// luminance seen through the camera at uniformly random image positions -- or BSDFs -- the mean
// sampling weight eval * cos / pdf for an incident direction at the listed `angles` in degrees,
// i.e. the directional albedo.
//
// `passes` (scenes only, default 1) is for integrators whose samples share per-pass state, such
// as a photon map: the samples of one pass are correlated through it, so a t-test over them
// would understate the variance. With passes = P > 1 the samples are split into P equal
// batches, batch b renders with its own pass data (preparePass with a seed of its own and pass
// index b: a fresh photon map, and in progressive mode the radius of pass b), and the t-test
// runs on the P independent batch means (P - 1 degrees of freedom).
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
        m_passes = props.getInteger("passes", 1);
        if (m_passes < 1) props.fail("passes must be at least 1, got %d", m_passes);
        if (m_passes > 1 && m_sampleCount % m_passes != 0)
            props.fail("sampleCount (%d) must be a multiple of passes (%d)", m_sampleCount,
                       m_passes);
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
            for (const auto& scene : m_scenes) {
                if (scene->camera()->outputSize().minCoeff() <= 0)
                    scene->fail("the camera has an empty image");
                // Light tracing reaches the image only through the film (renderUnit), never
                // through the Li() samples this test draws: the mean would miss it.
                if (scene->integrator()->hasPassSplats())
                    scene->fail(
                        "the integrator (%s) splats light paths onto the whole image, which the "
                        "t-test's samples of single camera rays cannot see; test it on rendered "
                        "passes instead (as common/integrator/vcm_test.cpp does)",
                        scene->integrator()->toString());
            }
        } else if (!m_bsdfs.empty()) {
            if (m_passes > 1) fail("\"passes\" applies to scenes only, not to BSDFs");
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
            if (!m_scenes.empty() && m_passes > 1) {
                const Scene& scene = *m_scenes[i];
                what = absl::StrFormat("scene %s, means of %d passes", scene.source(), m_passes);
                chunks = {sampleScenePasses(scene, static_cast<uint64_t>(i))};
            } else if (!m_scenes.empty()) {
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
    // With `begin`, chunk c accumulates samples [begin + c * kGrain, ...) up to `end`.
    template <typename SampleOnce>
    void sampleChunks(uint64_t testCase, std::vector<stats::RunningStats>& chunks,
                      SampleOnce&& sampleOnce, size_t begin = 0, size_t end = 0) const {
        if (end == 0) end = static_cast<size_t>(m_sampleCount);
        tbb::parallel_for(size_t{0}, chunks.size(), [&](size_t c) {
            std::unique_ptr<Sampler> sampler = m_sampler->clone();
            const size_t chunkEnd = std::min(end, begin + (c + 1) * kGrain);
            stats::RunningStats acc;
            for (size_t k = begin + c * kGrain; k < chunkEnd; ++k) {
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

    // Scene mode with `passes` batches: returns the statistics of the batch means. Batch b's
    // pass data comes from a seed of its own (so that integrators whose state depends on the
    // seed only, such as a non-progressive photon map, are independent between batches) and
    // pass index b; its camera samples are samples [b * n, (b + 1) * n) of the test case.
    stats::RunningStats sampleScenePasses(const Scene& scene, uint64_t testCase) const {
        const Camera& camera = *scene.camera();
        const Integrator& integrator = *scene.integrator();
        const Vector2f size = camera.outputSize().cast<float>();
        const size_t perPass = static_cast<size_t>(m_sampleCount / m_passes);
        stats::RunningStats means;
        for (int b = 0; b < m_passes; ++b) {
            const uint64_t passSeed = mix64(kTestSeed ^ mix64(testCase * 0x10000 + uint64_t(b)));
            const std::shared_ptr<const PassData> pass =
                integrator.preparePass(scene, passSeed, static_cast<uint64_t>(b));
            std::vector<stats::RunningStats> chunks((perPass + kGrain - 1) / kGrain);
            sampleChunks(
                testCase, chunks,
                [&](Sampler& sampler) {
                    const Point2f position = sampler.next2D().cwiseProduct(size);
                    const Point2f aperture = sampler.next2D();
                    Ray3f ray;
                    Color3f value = camera.sampleRay(ray, position, aperture);
                    if (!value.isBlack()) value *= integrator.Li(scene, sampler, ray, pass.get());
                    return value;
                },
                b * perPass, (b + 1) * perPass);
            stats::RunningStats batch;
            for (const stats::RunningStats& chunk : chunks) batch.merge(chunk);
            means.add(batch.mean);
        }
        return means;
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
    int m_passes;
    std::vector<float> m_angles, m_references;
    std::vector<std::shared_ptr<BSDF>> m_bsdfs;
    std::vector<std::shared_ptr<Scene>> m_scenes;
    std::shared_ptr<Sampler> m_sampler;
};

ALPHORN_REGISTER(Test, "ttest", StudentsTTest);

}  // namespace alphorn
