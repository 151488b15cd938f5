// A feature a scene does not use costs nothing, and the shortcuts that make it so do not change
// the expected image (bench_feature_cost measures the time; these tests the images):
//  - the volumetric path tracers on a scene without media or null surfaces run the surface path
//    tracer's loop: the film equals path_mis's / path_mats's byte for byte, and the volumetric
//    loop they no longer run there has the same mean (two-sample t-test);
//  - a constant heterogeneous medium renders exactly like the homogeneous one (same film), and
//    like the tracked medium it used to be (the same medium with a declared majorant) in the
//    mean (two-sample t-test over independent passes).
#include "common/integrator/integrator.h"
#include "common/integrator/volume.h"
#include "common/render/local_render.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "common/stats/student_t.h"
#include "common/texture/plugin_testing.h"
#include "tests/support/source_tree.h"

#include <absl/strings/str_format.h>
#include <gtest/gtest.h>

namespace alphorn {
namespace {

const std::string kMeshes = sourcePath("scenes/meshes/");

std::shared_ptr<Scene> load(const std::string& name, const std::string& xml) {
    return loadScene(plugin_testing::writeTempFile(name, xml));
}

std::string filmBytes(const Scene& scene, uint32_t passes, uint64_t seed = 0) {
    RenderSettings settings;
    settings.passes = passes;
    settings.seed = seed;
    return renderLocal(scene, settings).serialize();
}

// A small Cornell-like set: floor, back wall, a glass and a diffuse sphere, an area light and a
// point light; `extra` is added inside <scene>.
std::string surfaces(const std::string& integrator, const std::string& extra = "") {
    return absl::StrFormat(
        R"(<scene><integrator type="%s"/>
  <camera type="perspective"><transform name="toWorld"><lookat origin="0, 1, 3.5" target="0, 0.6, 0" up="0, 1, 0"/></transform>
    <float name="fov" value="45"/><integer name="width" value="16"/><integer name="height" value="16"/></camera>
  <mesh type="obj"><string name="filename" value="%squad.obj"/><transform name="toWorld"><scale value="2, 1, 2"/></transform>
    <bsdf type="diffuse"><color name="albedo" value="0.6"/></bsdf></mesh>
  <mesh type="obj"><string name="filename" value="%squad.obj"/><transform name="toWorld"><scale value="2, 1, 2"/><rotate axis="1, 0, 0" angle="90"/><translate value="0, 1, -1.5"/></transform>
    <bsdf type="diffuse"><color name="albedo" value="0.5, 0.6, 0.7"/></bsdf></mesh>
  <mesh type="obj"><string name="filename" value="%ssphere.obj"/><transform name="toWorld"><scale value="0.35, 0.35, 0.35"/><translate value="-0.4, 0.35, 0"/></transform>
    <bsdf type="dielectric"/></mesh>
  <mesh type="obj"><string name="filename" value="%ssphere.obj"/><transform name="toWorld"><scale value="0.3, 0.3, 0.3"/><translate value="0.5, 0.3, 0.2"/></transform>
    <bsdf type="diffuse"><color name="albedo" value="0.8"/></bsdf></mesh>
  <mesh type="obj"><string name="filename" value="%squad.obj"/><transform name="toWorld"><scale value="1, 1, 1"/><rotate axis="1, 0, 0" angle="180"/><translate value="0, 2, 0"/></transform>
    <emitter type="area"><color name="radiance" value="1.5"/></emitter></mesh>
  <emitter type="point"><point name="position" value="1, 1.5, 1"/><color name="power" value="8"/></emitter>
  %s
</scene>)",
        integrator, kMeshes, kMeshes, kMeshes, kMeshes, kMeshes, extra);
}

TEST(FeatureCost, VolumePathTracersWithoutMediaAreTheSurfacePathTracers) {
    for (const auto& [volumetric, surface] :
         {std::pair("volume_path_mis", "path_mis"), std::pair("volume_path_mats", "path_mats")}) {
        auto a = load("no_media_volume.xml", surfaces(volumetric));
        auto b = load("no_media_surface.xml", surfaces(surface));
        EXPECT_EQ(filmBytes(*a, 4), filmBytes(*b, 4)) << volumetric << " vs " << surface;
        // A null surface (here a sphere of vacuum) is a reason to run the volumetric loop.
        auto withNull =
            load("null_surface.xml",
                 surfaces(volumetric,
                          absl::StrFormat(
                              R"(<mesh type="obj"><string name="filename" value="%ssphere.obj"/>
            <transform name="toWorld"><scale value="0.2, 0.2, 0.2"/><translate value="0, 1.2, 0.5"/></transform><bsdf type="null"/></mesh>)",
                              kMeshes)));
        auto withNullSurface = load(
            "null_surface_path.xml",
            surfaces(surface, absl::StrFormat(
                                  R"(<mesh type="obj"><string name="filename" value="%ssphere.obj"/>
            <transform name="toWorld"><scale value="0.2, 0.2, 0.2"/><translate value="0, 1.2, 0.5"/></transform><bsdf type="null"/></mesh>)",
                                  kMeshes)));
        EXPECT_NE(filmBytes(*withNull, 4), filmBytes(*withNullSurface, 4))
            << volumetric << " should run its own loop on a scene with a null surface";
    }
}

// The shortcut keeps the expected image: volumePathLi itself (what volume_path_mis ran on such
// scenes before) and the integrator agree in the mean over image positions (Welch's t-test per
// integrator, fixed streams; the volumetric loop draws different numbers, so this is a
// statistical comparison).
TEST(FeatureCost, VolumetricLoopAndSurfaceLoopAgreeWithoutMedia) {
    for (const bool mis : {true, false}) {
        auto scene = load("agree.xml", surfaces(mis ? "volume_path_mis" : "volume_path_mats"));
        const Eigen::AlignedBox3f box = mediaBounds(*scene);
        std::unique_ptr<Sampler> sampler = scene->sampler()->clone();
        const Vector2f size = scene->camera()->outputSize().cast<float>();
        stats::RunningStats loop, integrator;
        // BSDF sampling alone finds the light less often: mats needs more samples.
        const int n = mis ? 30000 : 80000;
        for (int k = 0; k < n; ++k) {
            for (int which = 0; which < 2; ++which) {
                sampler->startStream(which ? 17 : 18, 0, uint64_t(k), StreamPurpose::Test);
                const Point2f position = sampler->next2D().cwiseProduct(size);
                Ray3f ray;
                const Color3f weight = scene->camera()->sampleRay(ray, position, sampler->next2D());
                const Color3f L = which ? volumePathLi(*scene, *sampler, ray, box, mis, mis)
                                        : scene->integrator()->Li(*scene, *sampler, ray, nullptr);
                (which ? loop : integrator).add(double(Color3f(weight * L).luminance()));
            }
        }
        const double se2a = loop.variance() / n, se2b = integrator.variance() / n;
        const double t = (loop.mean - integrator.mean) / std::sqrt(se2a + se2b);
        const double dof =
            (se2a + se2b) * (se2a + se2b) / (se2a * se2a / (n - 1) + se2b * se2b / (n - 1));
        const double p = stats::studentTTwoSidedPValue(t, dof);
        RecordProperty(mis ? "mis" : "mats", absl::StrFormat("%.5f vs %.5f, t %.2f, p %.3f",
                                                             loop.mean, integrator.mean, t, p));
        EXPECT_GT(p, 0.01) << (mis ? "mis" : "mats") << ": volumetric loop " << loop.mean
                           << ", integrator " << integrator.mean << ", t " << t;
        EXPECT_GT(integrator.mean, 0.05);
    }
}

// The chromatic sphere of scenes/seed/medium_sphere_chromatic.xml written three ways: homogeneous,
// heterogeneous with constant textures (rendered as the homogeneous one: the same film) and the
// latter with a declared majorant (tracked: different numbers, the same mean).
std::string mediumSphere(const std::string& integrator, const std::string& medium) {
    return absl::StrFormat(
        R"(<scene>%s
  <camera type="perspective"><transform name="toWorld"><lookat origin="0, 1.3, 4.5" target="0, 0.9, 0" up="0, 1, 0"/></transform>
    <float name="fov" value="30"/><integer name="width" value="12"/><integer name="height" value="12"/></camera>
  <mesh type="obj"><string name="filename" value="%squad.obj"/><transform name="toWorld"><scale value="4, 1, 4"/></transform>
    <bsdf type="diffuse"><color name="albedo" value="0.7"/></bsdf></mesh>
  <mesh type="obj"><string name="filename" value="%squad.obj"/><transform name="toWorld"><scale value="0.6, 1, 0.6"/><rotate axis="1, 0, 0" angle="180"/><translate value="0.8, 3.2, 1.2"/></transform>
    <emitter type="area"><color name="radiance" value="12"/></emitter></mesh>
  <emitter type="point"><point name="position" value="-1, 2, 1"/><color name="power" value="20"/></emitter>
  <mesh type="obj"><string name="filename" value="%ssphere.obj"/><transform name="toWorld"><scale value="0.9, 0.9, 0.9"/><translate value="0, 1, 0"/></transform>
    <bsdf type="null"/>%s</mesh>
</scene>)",
        integrator, kMeshes, kMeshes, kMeshes, medium);
}

const char* kHomogeneous =
    R"(<medium type="homogeneous" name="inside"><color name="sigmaS" value="%s"/><color name="sigmaA" value="%s"/></medium>)";
const char* kConstant =
    R"(<medium type="heterogeneous" name="inside">%s<texture type="constant" name="sigmaS"><color name="value" value="%s"/></texture>
       <texture type="constant" name="sigmaA"><color name="value" value="%s"/></texture></medium>)";

TEST(FeatureCost, ConstantHeterogeneousMediumRendersAsHomogeneous) {
    const char* integrators[] = {
        R"(<integrator type="volume_path_mis"/>)", R"(<integrator type="volume_path_mats"/>)",
        R"(<integrator type="volumetric_photonmapper"><integer name="photonCount" value="5000"/><boolean name="progressive" value="true"/></integrator>)"};
    // Chromatic (hero channel) and grey (equiangular sampling towards the point light).
    for (const auto& [s, a] :
         {std::pair("1.8, 1.8, 0.2", "0.2, 0.2, 1.8"), std::pair("1.5", "0.3")})
        for (const char* integrator : integrators) {
            auto homogeneous = load("homogeneous.xml",
                                    mediumSphere(integrator, absl::StrFormat(kHomogeneous, s, a)));
            auto constant = load("constant.xml",
                                 mediumSphere(integrator, absl::StrFormat(kConstant, "", s, a)));
            EXPECT_EQ(filmBytes(*homogeneous, 3), filmBytes(*constant, 3)) << integrator << s;
        }
}

// Image means over independent single passes of the reduced and the tracked medium: Welch's
// t-test on the mean luminance of the image, one value per pass.
TEST(FeatureCost, ConstantHeterogeneousMediumKeepsTheTrackedMean) {
    auto passMeans = [](const Scene& scene, uint64_t seedBase, int passes) {
        stats::RunningStats means;
        const Vector2i size = scene.camera()->outputSize();
        for (int k = 0; k < passes; ++k) {
            RenderSettings settings;
            settings.seed = seedBase + uint64_t(k);
            const Image image = resolveImage(renderLocal(scene, settings), size.x(), size.y());
            double sum = 0.0;
            for (int y = 0; y < size.y(); ++y)
                for (int x = 0; x < size.x(); ++x) sum += image.get(x, y).luminance();
            means.add(sum / (size.x() * size.y()));
        }
        return means;
    };
    for (const auto& [s, a, majorant] :
         {std::tuple("1.8, 1.8, 0.2", "0.2, 0.2, 1.8", "2"), std::tuple("1.5", "0.3", "1.8")}) {
        const std::string integrator = R"(<integrator type="volume_path_mis"/>)";
        auto reduced =
            load("reduced.xml", mediumSphere(integrator, absl::StrFormat(kConstant, "", s, a)));
        auto tracked = load(
            "tracked.xml",
            mediumSphere(
                integrator,
                absl::StrFormat(kConstant,
                                absl::StrFormat(R"(<float name="majorant" value="%s"/>)", majorant),
                                s, a)));
        const int n = 200;
        const stats::RunningStats x = passMeans(*reduced, 1000, n),
                                  y = passMeans(*tracked, 5000, n);
        const double se2x = x.variance() / n, se2y = y.variance() / n;
        const double t = (x.mean - y.mean) / std::sqrt(se2x + se2y);
        const double dof =
            (se2x + se2y) * (se2x + se2y) / (se2x * se2x / (n - 1) + se2y * se2y / (n - 1));
        const double p = stats::studentTTwoSidedPValue(t, dof);
        RecordProperty(
            std::string("sigmaS ") + s,
            absl::StrFormat("reduced %.5f, tracked %.5f, t %.2f, p %.3f", x.mean, y.mean, t, p));
        EXPECT_GT(p, 0.01) << s << ": reduced " << x.mean << ", tracked " << y.mean;
        EXPECT_GT(x.mean, 0.01);
    }
}

}  // namespace
}  // namespace alphorn
