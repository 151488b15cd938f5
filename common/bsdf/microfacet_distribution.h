// The anisotropic Trowbridge-Reitz (GGX) microfacet distribution with Smith's height-correlated
// masking-shadowing, shared by the conductor, the rough dielectric and the coated BSDFs. It
// follows pbrt-v4's conventions so that pbrt scenes keep their look: `alphaX` and `alphaY` are
// the roughnesses along the shading frame's x (tangent, pbrt's u) and y (v) axes, and
// roughnessToAlpha() is the mapping of pbrt-v4's `remaproughness`.
#pragma once

#include "common/core/common.h"
#include "common/core/frame.h"

namespace alphorn {

class TrowbridgeReitz {
  public:
    TrowbridgeReitz() = default;
    TrowbridgeReitz(float alphaX, float alphaY) : m_alphaX(alphaX), m_alphaY(alphaY) {}

    // pbrt-v4's `remaproughness`: a "roughness" in [0, 1] that looks perceptually linear maps to
    // alpha = sqrt(roughness).
    static float roughnessToAlpha(float roughness) { return std::sqrt(std::max(roughness, 0.0f)); }

    // Below this alpha pbrt-v4 treats the surface as a perfect mirror / refractor (a delta
    // lobe): the distribution's peak 1 / (pi alpha^2) would be beyond what sampling and float
    // evaluation can follow reliably, and the image is indistinguishable from a smooth surface.
    static constexpr float kSmoothAlpha = 1e-3f;
    bool effectivelySmooth() const { return std::max(m_alphaX, m_alphaY) < kSmoothAlpha; }
    bool isotropic() const { return m_alphaX == m_alphaY; }
    float alphaX() const { return m_alphaX; }
    float alphaY() const { return m_alphaY; }

    // Density of microfacet normals wm (per unit projected area: integral D(wm) cos = 1).
    float D(const Vector3f& wm) const {
        const float cos2 = wm.z() * wm.z();
        const float cos4 = cos2 * cos2;
        // Normals at grazing angles carry no projected area; the limit of D there is 0.
        if (cos4 < 1e-16f) return 0.0f;
        // tan^2 theta (cos^2 phi / alphaX^2 + sin^2 phi / alphaY^2), written without angles.
        const float e =
            (wm.x() * wm.x() / (m_alphaX * m_alphaX) + wm.y() * wm.y() / (m_alphaY * m_alphaY)) /
            cos2;
        const float onePlusE = 1.0f + e;
        return 1.0f / (Pi * m_alphaX * m_alphaY * cos4 * onePlusE * onePlusE);
    }

    // Smith's Lambda for direction w: G1(w) = 1 / (1 + Lambda(w)).
    float lambda(const Vector3f& w) const {
        const float cos2 = w.z() * w.z();
        if (cos2 == 0.0f) return std::numeric_limits<float>::infinity();
        // alpha^2 tan^2 along w's azimuth, from the projected components directly.
        const float a2tan2 =
            (m_alphaX * m_alphaX * w.x() * w.x() + m_alphaY * m_alphaY * w.y() * w.y()) / cos2;
        return 0.5f * (std::sqrt(1.0f + a2tan2) - 1.0f);
    }
    float G1(const Vector3f& w) const { return 1.0f / (1.0f + lambda(w)); }
    // Height-correlated masking and shadowing of the pair.
    float G(const Vector3f& wa, const Vector3f& wb) const {
        return 1.0f / (1.0f + lambda(wa) + lambda(wb));
    }

    // Density of the normals visible from w: G1(w) max(0, w.wm) D(wm) / |cos theta_w|. This is
    // the density of sampleVisibleNormal().
    float visibleD(const Vector3f& w, const Vector3f& wm) const {
        const float cosW = std::abs(w.z());
        if (cosW == 0.0f) return 0.0f;
        return G1(w) / cosW * D(wm) * std::abs(w.dot(wm));
    }

    // Samples a normal visible from w (either hemisphere: the lobe is mirrored for w.z < 0) with
    // density visibleD(w, wm): stretch the configuration to unit roughness, sample the projected
    // area of the unit hemisphere seen from the stretched w (a disk whose far half is squashed
    // by the hemisphere's own silhouette), and unstretch the normal.
    Vector3f sampleVisibleNormal(const Vector3f& w, const Point2f& u) const {
        Vector3f wh = Vector3f(m_alphaX * w.x(), m_alphaY * w.y(), w.z()).normalized();
        if (wh.z() < 0.0f) wh = -wh;
        const Vector3f t1 = wh.z() < 0.99999f ? Vector3f(0.0f, 0.0f, 1.0f).cross(wh).normalized()
                                              : Vector3f(1.0f, 0.0f, 0.0f);
        const Vector3f t2 = wh.cross(t1);
        // A uniform point on the unit disk by polar coordinates.
        const float r = std::sqrt(u.x()), phi = 2.0f * Pi * u.y();
        float px = r * std::cos(phi), py = r * std::sin(phi);
        const float h = std::sqrt(std::max(0.0f, 1.0f - px * px));
        const float s = 0.5f * (1.0f + wh.z());
        py = (1.0f - s) * h + s * py;
        const float pz = std::sqrt(std::max(0.0f, 1.0f - px * px - py * py));
        const Vector3f nh = px * t1 + py * t2 + pz * wh;
        return Vector3f(m_alphaX * nh.x(), m_alphaY * nh.y(), std::max(1e-6f, nh.z())).normalized();
    }

  private:
    float m_alphaX = 0.0f, m_alphaY = 0.0f;
};

}  // namespace alphorn
