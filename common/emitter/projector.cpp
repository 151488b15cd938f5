// <emitter type="projector">: a delta-position light that projects a texture through a
// perspective frustum, like a slide projector (PBRT v2's projection light).
//   fov           horizontal field of view in degrees, in (0, 180) (default 30); as for the
//                 camera, only a fov so narrow that float precision cannot hold it is refused
//   width height  only their ratio matters: the aspect of the projected image (default 1, 1)
//   toWorld       position and orientation: it shines along local +z with local +y up, like
//                 a camera; scaling in toWorld is ignored
//   power         the flux (a colour) it emits when the image is white (default 1)
//   <texture>     the projected image (any name; default white). Evaluated at the image uv --
//                 u from the image's left to right edge, v from bottom to top -- and at the
//                 point (x, y, 1) of the local image plane; negative values emit nothing
// A camera at the projector with the same fov and aspect sees the image upright and
// unmirrored. Intensity: I(w) = power / Omega * T(uv(w)) inside the frustum and zero outside
// and behind, where Omega = 4 asin(sin a sin b) is the frustum's solid angle (half-angles
// a, b), so power() = power / Omega * integral of T over the frustum, which is computed at
// activation by quadrature on a fine grid. Photons are drawn from a piecewise-constant
// distribution over that grid (with a small uniform floor so no lit direction has density 0).
#include "common/core/dpdf.h"
#include "common/core/frame.h"
#include "common/emitter/delta_light.h"
#include "common/texture/texture.h"

namespace alphorn {

class ProjectorLight : public DeltaPositionLight {
  public:
    explicit ProjectorLight(const PropertyList& props) {
        m_power = props.getNonNegativeColor("power", Color3f(1.0f));
        const float fov = props.getFloat("fov", 30.0f);
        if (!(fov > 0.0f && fov < 180.0f))
            props.fail("fov must be in (0, 180) degrees, got %g", fov);
        const int width = props.getPositiveInteger("width", 1);
        const int height = props.getPositiveInteger("height", 1);
        const Transform toWorld = props.getTransform("toWorld", Transform());
        m_position = toWorld.applyPoint(Point3f::Zero());
        const Vector3f n = toWorld.applyVector(Vector3f::UnitZ());
        const Vector3f x = toWorld.applyVector(Vector3f::UnitX());
        Vector3f s = x - n.normalized() * n.normalized().dot(x);
        if (!(n.norm() > 0.0f) || !(s.norm() > 0.0f)) props.fail("toWorld is degenerate");
        m_frame.n = n.normalized();
        m_frame.s = s.normalized();
        m_frame.t = m_frame.n.cross(m_frame.s);
        m_tanX = std::tan(degToRad(fov / 2.0f));
        m_tanY = m_tanX * static_cast<float>(height) / static_cast<float>(width);
        const double a = std::atan(double(m_tanX)), b = std::atan(double(m_tanY));
        m_solidAngle = 4.0 * std::asin(std::sin(a) * std::sin(b));
        // As for the camera, a narrow fov is refused only where float precision ends: the
        // intensity is power / Omega, and below about 3e-18 degrees (for a square image)
        // 1 / Omega exceeds the float range.
        if (!(m_tanY > 0.0f) || !std::isfinite(static_cast<float>(1.0 / m_solidAngle)))
            props.fail(
                "fov %g degrees (aspect %d:%d) is too narrow to render in float precision: the "
                "frustum's solid angle %g sr makes the intensity power / solid angle exceed the "
                "float range",
                fov, width, height, m_solidAngle);
        m_scale = m_power / static_cast<float>(m_solidAngle);
    }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        if (child->kind() != ObjectKind::Texture) return Emitter::addChild(child, name);
        if (m_texture) fail("a projector takes one texture");
        m_texture = std::static_pointer_cast<Texture>(child);
        m_texture->setParameterName(name);
    }

    void activate() override {
        // Quadrature of T(uv) J(uv) over the image, J = d omega / d(u, v), at kSub^2 points per
        // cell. The solid-angle weights are renormalised to the exact Omega, so a white image
        // gives exactly `power`.
        const int n = kGrid, sub = kSub;
        m_cells.clear();
        m_cells.reserve(size_t(n) * n);
        std::vector<double> cellMean(size_t(n) * n), cellJ(size_t(n) * n);
        double sumTJ[3] = {0.0, 0.0, 0.0}, sumJ = 0.0, maxMean = 0.0;
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                double tj[3] = {0.0, 0.0, 0.0}, jSum = 0.0, meanSum = 0.0;
                for (int sj = 0; sj < sub; ++sj)
                    for (int si = 0; si < sub; ++si) {
                        const Point2f uv((i + (si + 0.5f) / sub) / n, (j + (sj + 0.5f) / sub) / n);
                        const double jac = jacobian(uv);
                        const Color3f t = textureAt(uv);
                        for (int c = 0; c < 3; ++c) tj[c] += double(t[c]) * jac;
                        jSum += jac;
                        meanSum += double(t.mean());
                    }
                for (int c = 0; c < 3; ++c) sumTJ[c] += tj[c];
                sumJ += jSum;
                const size_t k = size_t(j) * n + i;
                cellMean[k] = meanSum / (sub * sub);
                cellJ[k] = jSum;
                maxMean = std::max(maxMean, cellMean[k]);
            }
        for (int c = 0; c < 3; ++c)
            m_totalPower[c] = static_cast<float>(m_scale[c] * m_solidAngle * sumTJ[c] / sumJ);
        m_cells.clear();
        for (size_t k = 0; k < cellMean.size(); ++k)
            m_cells.append((cellMean[k] + 0.01 * maxMean) * cellJ[k]);
        m_cells.normalize();
    }

    // Intensity (W/sr) towards the world direction `d` (unit); zero outside or behind.
    Color3f intensity(const Vector3f& d) const override {
        const Vector3f local = m_frame.toLocal(d);
        if (!(local.z() > 0.0f)) return Color3f(0.0f);
        const float x = local.x() / local.z(), y = local.y() / local.z();
        if (!(std::abs(x) <= m_tanX && std::abs(y) <= m_tanY)) return Color3f(0.0f);
        const Point2f uv(0.5f * (1.0f - x / m_tanX), 0.5f * (1.0f + y / m_tanY));
        return m_scale * textureAt(uv);
    }

    Color3f power() const override { return m_totalPower; }

    Color3f samplePhoton(Ray3f& ray, const Point2f&, const Point2f& sample) const override {
        if (!(m_cells.sum() > 0.0)) return Color3f(0.0f);
        float ux = sample.x();
        const size_t cell = m_cells.sampleReuse(ux);
        const int i = static_cast<int>(cell % kGrid), j = static_cast<int>(cell / kGrid);
        const Point2f uv((i + ux) / kGrid, (j + sample.y()) / kGrid);
        const float x = m_tanX * (1.0f - 2.0f * uv.x()), y = m_tanY * (2.0f * uv.y() - 1.0f);
        ray = Ray3f(m_position, m_frame.toWorld(Vector3f(x, y, 1.0f).normalized()));
        // pdf(w) = P(cell) / cellArea / J(uv); flux = I(w) / pdf(w).
        const double pdfUV = double(m_cells[cell]) * kGrid * kGrid;
        const double weight = jacobian(uv) / pdfUV;
        const Color3f flux = m_scale * textureAt(uv) * static_cast<float>(weight);
        return flux.isValid() ? flux : Color3f(0.0f);
    }

    std::string toString() const override { return "projector, power " + m_power.toString(); }

  private:
    static constexpr int kGrid = 256, kSub = 4;

    // d omega / d(u, v) at image coordinates uv.
    double jacobian(const Point2f& uv) const {
        const double x = double(m_tanX) * (1.0 - 2.0 * uv.x());
        const double y = double(m_tanY) * (2.0 * uv.y() - 1.0);
        const double r2 = 1.0 + x * x + y * y;
        return 4.0 * double(m_tanX) * double(m_tanY) / (r2 * std::sqrt(r2));
    }
    Color3f textureAt(const Point2f& uv) const {
        if (!m_texture) return Color3f(1.0f);
        const Point3f p(m_tanX * (1.0f - 2.0f * uv.x()), m_tanY * (2.0f * uv.y() - 1.0f), 1.0f);
        return m_texture->eval(uv, p).max(0.0f);
    }

    Frame m_frame;
    Color3f m_power, m_scale, m_totalPower;
    float m_tanX, m_tanY;
    double m_solidAngle;
    std::shared_ptr<Texture> m_texture;
    DiscretePDF m_cells;
};

ALPHORN_REGISTER(Emitter, "projector", ProjectorLight);

}  // namespace alphorn
