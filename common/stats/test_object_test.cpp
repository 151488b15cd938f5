// The <test type="ttest"> and <test type="chi2test"> objects end to end, through the parser:
// correct BSDFs pass, and deliberately broken ones (wrong pdf, NaN weights, wrong reference)
// fail, so the objects can fail when they should.
#include "common/stats/test_object.h"
#include "common/bsdf/bsdf.h"
#include "common/core/frame.h"
#include "common/core/warp.h"
#include "common/scene/parser.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace alphorn {
namespace {

// Samples the cosine-weighted hemisphere but claims a uniform density: the classic mismatch.
class WrongPdfBSDF : public BSDF {
  public:
    explicit WrongPdfBSDF(const PropertyList&) {}
    Color3f sample(BSDFQueryRecord& rec, const Point2f& u) const override {
        if (Frame::cosTheta(rec.wi) <= 0.0f) return Color3f(0.0f);
        rec.wo = warp::squareToCosineHemisphere(u);
        rec.measure = Measure::SolidAngle;
        return Color3f(0.5f);
    }
    Color3f eval(const BSDFQueryRecord&) const override { return Color3f(0.5f * InvPi); }
    float pdf(const BSDFQueryRecord& rec) const override {
        return Frame::cosTheta(rec.wi) > 0.0f && Frame::cosTheta(rec.wo) > 0.0f ? Inv2Pi : 0.0f;
    }
};
ALPHORN_REGISTER(BSDF, "test_wrong_pdf", WrongPdfBSDF);

// Returns NaN for one sample in a thousand: the mean is NaN, which must not pass.
class NanBSDF : public BSDF {
  public:
    explicit NanBSDF(const PropertyList&) {}
    Color3f sample(BSDFQueryRecord& rec, const Point2f& u) const override {
        rec.wo = warp::squareToCosineHemisphere(u);
        rec.measure = Measure::SolidAngle;
        return u.x() < 0.001f ? Color3f(NAN) : Color3f(0.5f);
    }
    Color3f eval(const BSDFQueryRecord&) const override { return Color3f(0.5f * InvPi); }
    float pdf(const BSDFQueryRecord& rec) const override {
        return Frame::cosTheta(rec.wo) > 0.0f ? Frame::cosTheta(rec.wo) * InvPi : 0.0f;
    }
};
ALPHORN_REGISTER(BSDF, "test_nan", NanBSDF);

class TestObjectTest : public ::testing::Test {
  protected:
    void SetUp() override {
        m_dir = std::filesystem::temp_directory_path() /
                ("alphorn_test_object_test_" + std::to_string(::getpid()));
        std::filesystem::create_directories(m_dir);
    }
    void TearDown() override { std::filesystem::remove_all(m_dir); }

    std::string write(const std::string& text) {
        const std::filesystem::path path = m_dir / "test.xml";
        std::ofstream(path) << text;
        return path.string();
    }
    // Parses and runs a test file; returns the summary and the printed report.
    StatisticalTest::Summary run(const std::string& text, std::string* report = nullptr) {
        std::shared_ptr<Object> root = parseSceneFile(write(text)).root;
        auto* test = dynamic_cast<StatisticalTest*>(root.get());
        EXPECT_NE(test, nullptr);
        if (!test) return {};
        std::ostringstream out;
        StatisticalTest::Summary summary = test->run(out);
        if (report) *report = out.str();
        return summary;
    }
    std::string parseError(const std::string& text) {
        try {
            parseSceneFile(write(text));
        } catch (const Error& e) {
            return e.what();
        }
        return "";
    }

    std::filesystem::path m_dir;
};

TEST_F(TestObjectTest, TTestDiffuseAlbedoPassesAndAWrongReferenceFails) {
    // Directional albedo of a diffuse BSDF is its albedo's luminance at every angle.
    const char* bsdf =
        R"(<bsdf type="diffuse"><color name="albedo" value="0.2, 0.5, 0.9"/></bsdf>)";
    const double y = 0.212671 * 0.2 + 0.715160 * 0.5 + 0.072169 * 0.9;
    std::string report;
    auto ok = run(absl::StrFormat(R"(<test type="ttest"><string name="angles" value="0, 45, 80"/>
        <string name="references" value="%.7f, %.7f, %.7f"/>%s</test>)",
                                  y, y, y, bsdf),
                  &report);
    EXPECT_EQ(ok.total, 3);
    EXPECT_TRUE(ok.allPassed()) << report;
    // The estimator is exact here (variance 0, floored at 1e-5): a 1% error is caught.
    auto bad = run(absl::StrFormat(R"(<test type="ttest"><string name="angles" value="30"/>
        <string name="references" value="%.7f"/>%s</test>)",
                                   y * 1.01, bsdf),
                   &report);
    EXPECT_EQ(bad.passed, 0) << report;
    EXPECT_NE(report.find("FAIL"), std::string::npos);
}

TEST_F(TestObjectTest, TTestNanFails) {
    std::string report;
    auto summary = run(R"(<test type="ttest"><string name="angles" value="0"/>
        <string name="references" value="0.5"/><bsdf type="test_nan"/></test>)",
                       &report);
    EXPECT_EQ(summary.total, 1);
    EXPECT_EQ(summary.passed, 0) << report;
    EXPECT_NE(report.find("non-finite"), std::string::npos) << report;
}

TEST_F(TestObjectTest, Chi2TestPassesDiffuseAndRejectsAWrongPdf) {
    std::string report;
    auto ok = run(R"(<test type="chi2test"><integer name="testCount" value="2"/>
        <integer name="sampleCount" value="200000"/><bsdf type="diffuse"/></test>)",
                  &report);
    EXPECT_EQ(ok.total, 2);
    EXPECT_TRUE(ok.allPassed()) << report;
    auto bad = run(R"(<test type="chi2test"><integer name="testCount" value="2"/>
        <integer name="sampleCount" value="200000"/><bsdf type="test_wrong_pdf"/></test>)",
                   &report);
    EXPECT_EQ(bad.total, 2);
    EXPECT_EQ(bad.passed, 0) << report;
}

TEST_F(TestObjectTest, RunsAreReproducible) {
    const char* text = R"(<test type="chi2test"><integer name="testCount" value="1"/>
        <integer name="sampleCount" value="100000"/><bsdf type="diffuse"/></test>)";
    std::string a, b;
    run(text, &a);
    run(text, &b);
    EXPECT_EQ(a, b);
}

TEST_F(TestObjectTest, BadFilesNameTheProblem) {
    EXPECT_NE(parseError(R"(<test type="ttest"><string name="references" value="1, x"/>
        <bsdf type="diffuse"/></test>)")
                  .find("could not parse the number \"x\""),
              std::string::npos);
    EXPECT_NE(parseError(R"(<test type="ttest"><string name="angles" value="0, 10"/>
        <string name="references" value="1"/><bsdf type="diffuse"/></test>)")
                  .find("2 angles but 1 references"),
              std::string::npos);
    EXPECT_NE(parseError(R"(<test type="ttest"><string name="references" value="1"/></test>)")
                  .find("nothing to test"),
              std::string::npos);
    EXPECT_NE(parseError(R"(<test type="chi2test"><float name="significanceLevel" value="2"/>
        <bsdf type="diffuse"/></test>)")
                  .find("significanceLevel must be in (0, 1)"),
              std::string::npos);
    EXPECT_NE(parseError(R"(<test type="ttest"><string name="references" value="nan"/>
        <string name="angles" value="0"/><bsdf type="diffuse"/></test>)")
                  .find("not finite"),
              std::string::npos);
    // Every message starts with the file and line.
    EXPECT_NE(parseError(R"(<test type="chi2test"/>)").find("test.xml:1:"), std::string::npos);
}

}  // namespace
}  // namespace alphorn
