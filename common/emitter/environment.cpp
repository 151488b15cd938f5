// <emitter type="environment">: light arriving from infinitely far away in every direction, a
// constant colour or an image of the sky (pbrt's "infinite" light).
//   radiance     colour: a constant environment (default 1 when no file is given)
//   filename     an OpenEXR (.exr) or PFM (.pfm) image of the radiance; not with `radiance`.
//                Non-finite pixels are refused; negative ones emit nothing
//   mapping      how the image covers the sphere of directions, in the light's space:
//                "equirect" (default): latitude-longitude, +y up: row 0 is +y, the last row -y;
//                  u = phi / 2pi with phi = atan2(x, -z) in [0, 2pi), so the left edge looks
//                  along -z, a quarter across +x, the centre +z, three quarters -x
//                "octahedral": pbrt-v4's equal-area octahedral square (Clarberg's mapping):
//                  +z at the centre of the image, -z at its four corners, +x the middle of the
//                  right edge, +y the middle of the bottom row; the image must be square
//   scale        float multiplying the radiance (default 1)
//   illuminance  optional float: normalises the map so that a surface facing the light space's
//                +z, open to the whole upper hemisphere, receives this illuminance (luminance Y
//                weighted by cos theta over the hemisphere; pi * Y(L) for a constant), times
//                `scale`, which still multiplies as in pbrt-v4
//   toWorld      rotation from the light's space to the world (a uniform scale is ignored;
//                shear or non-uniform scale is refused)
//   portal       accepted (as a string) and ignored with a warning: pbrt uses it only to sample
//                the map through a window, which changes noise, not the image
// Images are looked up by nearest pixel, for eval and for the sampling distribution alike, so
// the map is exactly piecewise constant and pdf() is exactly the density sample() draws from:
// pixels are chosen in proportion to mean colour times solid angle (a row distribution, then a
// column within the row), then a uniform point within the pixel's (u, v) cell; the density in
// solid angle divides by the mapping's Jacobian: 2 pi^2 sin theta for equirect, 4 pi (equal area)
// for octahedral. A constant environment is sampled uniformly over the sphere.
#include "common/core/dpdf.h"
#include "common/core/image.h"
#include "common/core/warning.h"
#include "common/emitter/infinite.h"
#include "common/emitter/sphere_mapping.h"

#include <absl/strings/ascii.h>

#include <filesystem>

namespace alphorn {

namespace {

enum class Mapping { Equirect, Octahedral };

}  // namespace

class EnvironmentLight : public InfiniteEmitter {
  public:
    explicit EnvironmentLight(const PropertyList& props) {
        const std::string mapping = props.getString("mapping", "equirect");
        if (mapping == "equirect")
            m_mapping = Mapping::Equirect;
        else if (mapping == "octahedral")
            m_mapping = Mapping::Octahedral;
        else
            props.fail("\"mapping\" must be \"equirect\" or \"octahedral\", got \"%s\"", mapping);
        float scale = props.getNonNegativeFloat("scale", 1.0f);
        if (!std::isfinite(scale)) props.fail("\"scale\" must be finite, got %g", scale);
        readRotation(props);
        if (props.has("portal")) {
            props.getString("portal");
            warn("%s: \"portal\" is ignored (it only changes how the map is sampled)",
                 props.source());
        }

        if (props.has("filename")) {
            if (props.has("radiance"))
                props.fail("give either \"radiance\" or \"filename\", not both");
            readImage(props);
        } else {
            m_radiance = props.getNonNegativeColor("radiance", Color3f(1.0f));
            if (!m_radiance.allFinite()) props.fail("\"radiance\" must be finite");
            m_integral = 4.0f * Pi * m_radiance;
        }

        if (props.has("illuminance")) {
            const float target = props.getPositiveFloat("illuminance", 1.0f);
            if (!std::isfinite(target))
                props.fail("\"illuminance\" must be finite, got %g", target);
            // As in pbrt-v4, `scale` still multiplies: the map alone is normalised.
            const double current = upperIlluminance();
            if (!(current > 0.0) || !std::isfinite(current))
                props.fail(
                    "\"illuminance\": the map sends no light to a surface facing +z, so no scale "
                    "gives it illuminance %g",
                    target);
            scale = float(double(scale) * target / current);
        }
        m_radiance *= scale;
        for (float& v : m_image.rgb) v *= scale;
        m_integral *= scale;
        if (!m_radiance.allFinite() || !m_integral.allFinite())
            props.fail("the scaled radiance exceeds the float range");
    }

    Color3f eval(const EmitterQueryRecord& rec) const override {
        if (m_image.width == 0) return m_radiance;
        const Vector3f d = m_toLocal * rec.wi;
        if (!d.allFinite() || d.isZero()) return Color3f(0.0f);
        const Point2i pixel = pixelOf(d.normalized());
        return m_image.get(pixel.x(), pixel.y());
    }

    float pdf(const EmitterQueryRecord& rec) const override {
        if (m_image.width == 0) return Inv4Pi;
        const Vector3f d = m_toLocal * rec.wi;
        if (!d.allFinite() || d.isZero()) return 0.0f;
        return pdfLocal(d.normalized());
    }

    Color3f sample(EmitterQueryRecord& rec, const Point2f& u) const override {
        const Vector3f wi = sampleDirection(u);
        if (wi.isZero()) {
            rec.pdf = 0.0f;
            return Color3f(0.0f);
        }
        aimAtDirection(rec, wi);
        // pdf() and eval() of the direction itself: radiance / pdf is eval / pdf exactly.
        rec.pdf = pdf(rec);
        if (!(rec.pdf > 0.0f) || !std::isfinite(rec.pdf)) {
            rec.pdf = 0.0f;
            return Color3f(0.0f);
        }
        const Color3f result = eval(rec) / rec.pdf;
        return result.allFinite() ? result : Color3f(0.0f);
    }

    // The flux through the disk the bounding sphere casts, from every direction: pi r^2 times
    // the radiance integrated over the sphere of directions.
    Color3f power() const override { return diskArea() * m_integral; }

    Color3f samplePhoton(Ray3f& ray, const Point2f& positionSample,
                         const Point2f& directionSample) const override {
        const Vector3f wi = sampleDirection(directionSample);
        if (wi.isZero()) return Color3f(0.0f);
        EmitterQueryRecord rec(m_centre);
        aimAtDirection(rec, wi);
        const float pdf = this->pdf(rec);
        if (!(pdf > 0.0f)) return Color3f(0.0f);
        ray = diskRay(wi, positionSample);
        // Direction density pdf, position density 1 / area on the disk facing it.
        const Color3f flux = eval(rec) * diskArea() / pdf;
        return flux.allFinite() ? flux : Color3f(0.0f);
    }

    std::string toString() const override {
        if (m_image.width == 0) return "environment light, radiance " + m_radiance.toString();
        return "environment light, " + std::to_string(m_image.width) + "x" +
               std::to_string(m_image.height) +
               (m_mapping == Mapping::Equirect ? " equirect map" : " octahedral map");
    }

  private:
    void readRotation(const PropertyList& props) {
        const Transform toWorld = props.getTransform("toWorld", Transform());
        Matrix3f m = toWorld.matrix().topLeftCorner<3, 3>();
        // A uniform scale does not change directions; divide it out, then demand a rotation (or
        // a mirror), which keeps solid angles and so the densities.
        const float det = m.determinant();
        const float s = std::cbrt(std::abs(det));
        if (!(s > 0.0f) || !std::isfinite(s)) props.fail("\"toWorld\" is singular");
        m /= s;
        if (!((m.transpose() * m - Matrix3f::Identity()).cwiseAbs().maxCoeff() < 1e-3f))
            props.fail("\"toWorld\" must be a rotation (shear and non-uniform scale are refused)");
        m_toWorld = m;
        m_toLocal = m.transpose();
    }

    void readImage(const PropertyList& props) {
        const std::string path = props.resolvePath(props.getString("filename"));
        if (!std::filesystem::is_regular_file(path))
            props.fail("the environment map \"%s\" does not exist", path);
        const std::string extension =
            absl::AsciiStrToLower(std::filesystem::path(path).extension().string());
        try {
            if (extension == ".exr")
                m_image = readEXR(path);
            else if (extension == ".pfm")
                m_image = readPFM(path);
            else
                props.fail("unsupported environment map \"%s\" (expected .exr or .pfm)", path);
        } catch (const Error& e) {
            props.rethrowHere(e);
        }
        if (m_image.width <= 0 || m_image.height <= 0)
            props.fail("the environment map \"%s\" is empty", path);
        if (m_mapping == Mapping::Octahedral && m_image.width != m_image.height)
            props.fail("an octahedral environment map must be square; \"%s\" is %dx%d", path,
                       m_image.width, m_image.height);
        for (float& v : m_image.rgb) {
            if (!std::isfinite(v))
                props.fail("the environment map \"%s\" has non-finite values", path);
            v = std::max(v, 0.0f);
        }
        buildDistribution();
    }

    // Solid angle of the pixels of row `y`.
    double pixelSolidAngle(int y) const {
        const int w = m_image.width, h = m_image.height;
        if (m_mapping == Mapping::Octahedral) return 4.0 * M_PI / (double(w) * h);
        const double theta0 = M_PI * y / h, theta1 = M_PI * (y + 1) / h;
        return 2.0 * M_PI / w * (std::cos(theta0) - std::cos(theta1));
    }

    void buildDistribution() {
        const int w = m_image.width, h = m_image.height;
        m_rows.clear();
        m_rows.reserve(h);
        m_columns.assign(h, DiscretePDF());
        double integral[3] = {0.0, 0.0, 0.0};
        for (int y = 0; y < h; ++y) {
            const double omega = pixelSolidAngle(y);
            DiscretePDF& row = m_columns[y];
            row.clear();
            row.reserve(w);
            for (int x = 0; x < w; ++x) {
                const Color3f c = m_image.get(x, y);
                row.append(double(c.mean()) * omega);
                for (int k = 0; k < 3; ++k) integral[k] += double(c[k]) * omega;
            }
            m_rows.append(row.normalize());
        }
        m_rows.normalize();
        m_integral = Color3f(float(integral[0]), float(integral[1]), float(integral[2]));
    }

    // Illuminance (luminance Y times cos theta over the upper hemisphere) on a surface facing
    // the light space's +z, before `scale`: pi Y for a constant; for a map, each pixel's solid
    // angle times the cosine at its centre (the midpoint rule).
    double upperIlluminance() const {
        if (m_image.width == 0) return M_PI * double(m_radiance.luminance());
        double sum = 0.0;
        for (int y = 0; y < m_image.height; ++y) {
            const double omega = pixelSolidAngle(y);
            for (int x = 0; x < m_image.width; ++x) {
                const Point2f uv((x + 0.5f) / m_image.width, (y + 0.5f) / m_image.height);
                const float cosTheta = toDirection(uv).z();
                if (cosTheta > 0.0f)
                    sum += double(m_image.get(x, y).luminance()) * cosTheta * omega;
            }
        }
        return sum;
    }

    Point2f toUV(const Vector3f& d) const {
        return m_mapping == Mapping::Equirect ? equirectFromDirection(d)
                                              : octahedralFromDirection(d);
    }
    Vector3f toDirection(const Point2f& uv) const {
        return m_mapping == Mapping::Equirect ? equirectToDirection(uv) : octahedralToDirection(uv);
    }

    Point2i pixelOf(const Vector3f& d) const {
        const Point2f uv = toUV(d);
        // The clamps keep u = 1 (phi = 2 pi after rounding) and v = 1 on the last pixel.
        const int x = std::clamp(int(uv.x() * m_image.width), 0, m_image.width - 1);
        const int y = std::clamp(int(uv.y() * m_image.height), 0, m_image.height - 1);
        return Point2i(x, y);
    }

    float pdfLocal(const Vector3f& d) const {
        if (!(m_rows.sum() > 0.0)) return 0.0f;
        const Point2i pixel = pixelOf(d);
        // The pixel's probability over its (u, v) area 1 / (w h), then over the Jacobian.
        const float uvDensity = m_rows[pixel.y()] * m_columns[pixel.y()][pixel.x()] *
                                float(m_image.width) * float(m_image.height);
        if (m_mapping == Mapping::Octahedral) return uvDensity * Inv4Pi;
        // From x and z, not 1 - y^2: near the poles y rounds to 1 while sin theta is not 0.
        const float sinTheta = std::sqrt(d.x() * d.x() + d.z() * d.z());
        const float pdf = uvDensity / (2.0f * Pi * Pi * sinTheta);
        return std::isfinite(pdf) ? pdf : 0.0f;
    }

    // A unit world direction drawn from the sampling distribution; zero when the map is black.
    Vector3f sampleDirection(Point2f u) const {
        if (m_image.width == 0) return warp::squareToUniformSphere(u);
        if (!(m_rows.sum() > 0.0)) return Vector3f::Zero();
        float uy = u.y(), ux = u.x();
        const size_t y = m_rows.sampleReuse(uy);
        const size_t x = m_columns[y].sampleReuse(ux);
        const Point2f uv((float(x) + ux) / float(m_image.width),
                         (float(y) + uy) / float(m_image.height));
        const Vector3f world = m_toWorld * toDirection(uv);
        const float length = world.norm();
        return length > 0.0f ? Vector3f(world / length) : Vector3f::Zero();
    }

    Mapping m_mapping = Mapping::Equirect;
    Matrix3f m_toWorld = Matrix3f::Identity(), m_toLocal = Matrix3f::Identity();
    Color3f m_radiance = Color3f(0.0f);  // the constant environment (no image)
    Image m_image;                       // scaled radiance; empty for a constant environment
    DiscretePDF m_rows;                  // row weights
    std::vector<DiscretePDF> m_columns;  // pixel weights within each row
    Color3f m_integral = Color3f(0.0f);  // radiance integrated over the sphere
};

ALPHORN_REGISTER(Emitter, "environment", EnvironmentLight);

// The map an environment light reads, for listing a scene's files: found, not decoded.
void listEnvironmentFile(const PropertyList& props) {
    if (!props.has("filename")) return;
    const std::string path = props.resolvePath(props.getString("filename"));
    if (!std::filesystem::is_regular_file(path))
        props.fail("the environment map \"%s\" does not exist", path);
}
ALPHORN_REGISTER_FILES(Emitter, "environment", listEnvironmentFile);

}  // namespace alphorn
