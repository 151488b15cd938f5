// <bsdf type="normalmap">: shades a nested BSDF with normals from a texture.
//   <bsdf ...>                           the nested BSDF (any name)
//   <texture name="normalmap" ...>       the normal map, e.g. a bitmap with raw=true
// At the query's uv and position the texture's rgb gives n = 2 rgb - 1 in the local shading
// frame (so rgb (0.5, 0.5, 1) is the unperturbed normal). The perturbed frame has normal n and
// tangent the local x axis made orthogonal to n; the nested BSDF is evaluated and sampled in
// it. eval() is rescaled by |cos theta_o'| / |cos theta_o| so that the integrators' cosine
// with the true normal turns into the perturbed one: the result is the nested BSDF's own
// integrand f' cos' (the visible shading of the bumps), whose integral over the outgoing
// directions is at most the nested albedo. Directions on different sides of the true and the
// perturbed surface (light leaking through either) get zero.
// A normal at less than kMinCos above the horizon (or below it) is bent back onto
// cos theta = kMinCos in its azimuth; a zero or non-finite one counts as unperturbed.
#include "common/bsdf/bsdf.h"
#include "common/core/frame.h"
#include "common/texture/texture.h"

namespace alphorn {

class NormalMap : public BSDF {
  public:
    explicit NormalMap(const PropertyList&) {}

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        if (child->kind() == ObjectKind::BSDF) {
            if (m_nested) fail("normalmap takes exactly one nested BSDF");
            m_nested = std::static_pointer_cast<BSDF>(child);
        } else if (child->kind() == ObjectKind::Texture) {
            if (name != "normalmap")
                fail("normalmap has no texture parameter \"%s\" (textures: normalmap)", name);
            if (m_normals) fail("normalmap takes one normal texture");
            m_normals = std::static_pointer_cast<Texture>(child);
            m_normals->setParameterName(name);
        } else {
            BSDF::addChild(child, name);
        }
    }

    void activate() override {
        if (!m_nested) fail("normalmap needs a nested <bsdf>");
        if (!m_normals) fail("normalmap needs a <texture name=\"normalmap\">");
    }

    Color3f eval(const BSDFQueryRecord& rec) const override {
        BSDFQueryRecord r = perturb(rec);
        if (!sameSide(rec.wi.z(), r.wi.z()) || !sameSide(rec.wo.z(), r.wo.z()))
            return Color3f(0.0f);
        return m_nested->eval(r) * (std::abs(r.wo.z()) / std::abs(rec.wo.z()));
    }

    float pdf(const BSDFQueryRecord& rec) const override {
        // A rotation preserves solid angle, so densities carry over unchanged.
        BSDFQueryRecord r = perturb(rec);
        if (!sameSide(rec.wi.z(), r.wi.z()) || !sameSide(rec.wo.z(), r.wo.z())) return 0.0f;
        return m_nested->pdf(r);
    }

    Color3f sample(BSDFQueryRecord& rec, const Point2f& sample) const override {
        const Frame frame = perturbedFrame(rec.uv, rec.p);
        BSDFQueryRecord r(frame.toLocal(rec.wi));
        r.uv = rec.uv;
        r.p = rec.p;
        if (!sameSide(rec.wi.z(), r.wi.z())) return Color3f(0.0f);
        const Color3f weight = m_nested->sample(r, sample);
        rec.wo = frame.toWorld(r.wo);
        rec.eta = r.eta;
        rec.measure = r.measure;
        if (weight.isBlack() || !sameSide(rec.wo.z(), r.wo.z())) return Color3f(0.0f);
        // eval * |cos| / pdf with the rescaled eval is the nested weight itself.
        return weight;
    }

    bool isDiffuse() const override { return m_nested->isDiffuse(); }
    bool needsTangentFrame() const override { return true; }
    std::string toString() const override { return "normalmap of " + m_nested->toString(); }

    static constexpr float kMinCos = 0.02f;

  private:
    static bool sameSide(float a, float b) {
        return (a > 0.0f && b > 0.0f) || (a < 0.0f && b < 0.0f);
    }

    // The perturbed frame, in local shading coordinates. For n = (0, 0, 1) every operation
    // below is exact, so the frame is the identity and the nested BSDF is reproduced exactly.
    Frame perturbedFrame(const Point2f& uv, const Point3f& p) const {
        const Color3f c = m_normals->eval(uv, p);
        Vector3f n(2.0f * c.r() - 1.0f, 2.0f * c.g() - 1.0f, 2.0f * c.b() - 1.0f);
        const float length = n.norm();
        if (!(length > 0.0f) || !std::isfinite(length)) return Frame();
        n /= length;
        if (!(n.z() >= kMinCos)) {
            const float xy = std::hypot(n.x(), n.y());
            if (!(xy > 0.0f)) return Frame();  // straight down: no azimuth to keep
            const float scale = std::sqrt(1.0f - kMinCos * kMinCos) / xy;
            n = Vector3f(n.x() * scale, n.y() * scale, kMinCos);
        }
        // Gram-Schmidt of the local x axis keeps anisotropic nested BSDFs aligned.
        const Vector3f s = (Vector3f::UnitX() - n * n.x()).normalized();
        return Frame(s, n.cross(s), n);
    }

    BSDFQueryRecord perturb(const BSDFQueryRecord& rec) const {
        const Frame frame = perturbedFrame(rec.uv, rec.p);
        BSDFQueryRecord r(frame.toLocal(rec.wi), frame.toLocal(rec.wo), rec.measure);
        r.eta = rec.eta;
        r.uv = rec.uv;
        r.p = rec.p;
        return r;
    }

    std::shared_ptr<BSDF> m_nested;
    std::shared_ptr<Texture> m_normals;
};

ALPHORN_REGISTER(BSDF, "normalmap", NormalMap);

}  // namespace alphorn
