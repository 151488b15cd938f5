// <integrator type="volumetric_photonmapper">: photon mapping with a surface and a volume photon
// map, the volume radiance estimated by the beam radiance estimate (Jarosz, Zwicker, Jensen
// 2008); fixed radii or k nearest neighbours; progressive mode with the Knaus–Zwicker schedule
// applied to both radii.
//
// Photons: one tracing loop (tracePhotonsThroughMedia) fills both maps. Photon paths fly through
// media by the media's own free-flight sampling and scatter by their phase functions; a photon is
// stored at every scattering event (volume map) and at every non-delta surface hit (surface
// map). Path i feeds the surface map when i < surfacePhotonCount and the volume map when
// i < volumePhotonCount, and each map's power is divided by its own count of paths (emitted, not
// stored; 64-bit).
//
// Camera paths: from the camera through delta surfaces to the first non-delta surface. Each
// straight piece of the path (through any index-matched, null, boundaries, which do not bend it)
// adds the beam estimate
//
//     L_b = Σ_i T(o → o + t_i d) · phase_i(−d, ω_i) · Φ_i / (π r_i²),
//
// over the volume photons i whose spheres of radius r_i the piece crosses (t_i, the parameter of
// the point closest to photon i, in [0, end of the piece]), phase_i the phase function of the
// medium photon i scattered in, and multiplies the path by the piece's transmittance; the
// non-delta surface at the end adds its photon density estimate. T is the media's own
// transmittance(): closed form for homogeneous media, ratio tracking for heterogeneous ones,
// walked once along the piece from photon to photon (a product of independent unbiased factors
// is unbiased). One query over the whole piece, rather than one per medium segment, keeps the
// photons near a medium's boundary whose closest points fall just outside it: a query per
// segment loses them (2% of the light of the agreement test's sphere).
//
// σs at the photon: the estimate is often written with a factor σs(x_i) Φ_i, for photons whose
// density estimates the fluence. Our stored Φ_i is the flux after the scattering event's weight,
// which already holds σs(x_i) (σs/σt at a homogeneous collision, whose density is σt·T; the
// collision's probability σs/μ in delta tracking), so Σ Φ_i / V estimates σs · fluence and no
// further factor belongs here. With one, media of varying σs come out wrong: the Perlin cases of
// volumetric_photonmapper_furnace_ttest.xml and the exponential sphere of
// volumetric_photonmapper_agreement_ttest.xml check it.
//
// Direct light is counted exactly once; emitters add their radiance only where a camera path
// sees them, attenuated by the media in between. In the media, photons carry all of it, single
// scattering included. At the first non-delta surface, `directLight` chooses as in
// photonmapper: "photons" (the photons carry it) or "nee" (one light sample with the
// transmittance of the media along the shadow ray, sampleLightThroughMedia() of the volume path
// tracers without MIS, and the photon tracer skips each path's surface photon of light that
// reached a surface without scattering on the way, by a surface or in a medium; null
// boundaries do not count, as the shadow ray crosses them too).
//
// Passes: as photonmapper. Without `progressive`, one pair of maps per (scene, seed), built from
// pass 0's streams; with it, pass i traces its own photons and gathers at the surface and volume
// radii of pass i from the one shared schedule (radius_schedule.h). radiusSchedule() reports the
// surface radius (the progress line shows one number; both follow the same ratio). With
// `volumeK`, each photon's kNN radius is shrunk by the schedule's factor r_i / r_0, as the
// surface kNN radii are (photon_mapping.cpp): the kernel still integrates to one, and its blur
// vanishes as the passes go on.
//
// Bias estimate (progressive mode, fixed radii or kNN): LiTwoRadii() also returns the image at the
// smaller radii, every surface disk and every photon's beam disk shrunk to
// kSmallerRadiusAreaRatio (1/2) of its area, from the same queries, camera path and
// transmittance estimates (the main image's floats are Li()'s). The film's two-radii estimate
// assumes a bias proportional to r². The beam kernel blurs only across the line (the closest
// point t_i is exact along it): a disc of radius r over the line integral of in-scattered light,
// whose first-order term cancels by symmetry where that light is smooth across the beams, so
// the order is 2 there as for surfaces. At a medium's boundary (radius not small against the
// mean free path) and at edges of light in a medium it falls slower and the estimate is low
// (docs/error-estimate.md; bench/atlas/bias_probes.py measures both).
#include "common/integrator/photon_mapping.h"
#include "common/integrator/volume.h"
#include "common/photon/photon_tracer.h"
#include "common/scene/scene.h"

#include <absl/strings/str_format.h>

namespace alphorn {

class VolumetricPhotonMapper : public PhotonMappingIntegrator {
  public:
    // Direct light from photons by default: next-event estimation at surfaces measured ahead in
    // one media scene so far (bench/RESULTS.md), too few to change what every scene renders.
    explicit VolumetricPhotonMapper(const PropertyList& props)
        : PhotonMappingIntegrator(props, "photons") {
        m_surfaceCount = photonCount(props, "surfacePhotonCount", m_photonCount);
        m_volumeCount = photonCount(props, "volumePhotonCount", m_photonCount);
        m_volumeRadiusGiven = props.has("volumePhotonRadius");
        m_volumeRadius = props.getFloat("volumePhotonRadius", 0.0f);
        if (m_volumeRadiusGiven && !(m_volumeRadius > 0.0f && std::isfinite(m_volumeRadius)))
            props.fail("\"volumePhotonRadius\" must be positive and finite, got %g",
                       m_volumeRadius);
        m_volumeK = props.getInteger("volumeK", 0);
        if (props.has("volumeK") && m_volumeK < 2)
            props.fail("\"volumeK\" must be at least 2, got %d", m_volumeK);
        // A volume photon is the record and the medium it scattered in.
        const uint64_t volumeBytes = sizeof(Photon) + sizeof(const Medium*);
        checkPassMemory(
            props,
            absl::StrFormat("%u surface and %u volume photon paths (\"photonCount\", "
                            "\"surfacePhotonCount\", \"volumePhotonCount\")",
                            m_surfaceCount, m_volumeCount),
            m_surfaceCount * sizeof(Photon) + m_volumeCount * volumeBytes,
            absl::StrFormat("%zu bytes per surface and %u per volume photon path for "
                            "one stored photon; paths that bounce or scatter store more",
                            sizeof(Photon), volumeBytes));
        checkNeighbourCount(props, "surfaceK", m_surfaceK);
        checkNeighbourCount(props, "volumeK", m_volumeK);
    }

    void preprocess(const Scene& scene) override {
        PhotonMappingIntegrator::preprocess(scene);
        // The volume default is 1/100 of the diagonal (a beam crosses few photons at Nori's
        // surface radius); a kNN search without a given radius may reach across the scene.
        const float diagonal = sceneDiagonal(scene);
        if (!m_volumeRadiusGiven) m_volumeRadius = m_volumeK > 0 ? diagonal : diagonal / 100.0f;
        if (!(m_volumeRadius > 0.0f && std::isfinite(m_volumeRadius)))
            fail(
                "cannot derive a volume photon radius from the scene's bounds; give "
                "\"volumePhotonRadius\"");
        m_mediaBox = mediaBounds(scene);
        m_hasMedia = sceneHasMedia(scene);
    }

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
               const PassData* passData) const override {
        return trace<false>(scene, sampler, cameraRay, passData).atPassRadius;
    }

    bool estimatesBiasWithTwoRadii() const override { return gathersAtTwoRadii(); }
    TwoRadiiRadiance LiTwoRadii(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
                                const PassData* passData) const override {
        if (!gathersAtTwoRadii())
            fail("volumetric_photonmapper gathers at two radii only in progressive mode");
        return trace<true>(scene, sampler, cameraRay, passData);
    }

    std::string toString() const override {
        auto lookup = [](int k, float radius) {
            return k > 0 ? absl::StrFormat("%d nearest neighbours within %g", k, radius)
                         : absl::StrFormat("radius %g", radius);
        };
        return absl::StrFormat(
            "volumetric_photonmapper (%u surface and %u volume photon paths per pass; surface %s; "
            "volume %s%s; direct light on surfaces %s)",
            m_surfaceCount, m_volumeCount, lookup(m_surfaceK, surfaceRadius()),
            lookup(m_volumeK, m_volumeRadius),
            m_progressive ? absl::StrFormat("; progressive, alpha %g", m_alpha) : "",
            samplesDirectLight() ? "sampled" : "from photons");
    }

  private:
    static uint64_t photonCount(const PropertyList& props, const std::string& name,
                                uint64_t fallback) {
        const int count = props.getInteger(name, static_cast<int>(fallback));
        if (count < 0)
            props.fail("\"%s\" (photon paths per pass) must be at least 0, got %d", name, count);
        return static_cast<uint64_t>(count);
    }

    // Does any light interaction happen in a medium? Without, no volume photon is traced.
    static bool sceneHasMedia(const Scene& scene) {
        if (isParticipating(scene.camera()->medium())) return true;
        return scene.findMesh([](const Mesh& mesh) {
            return isParticipating(mesh.insideMedium()) || isParticipating(mesh.outsideMedium());
        }) != nullptr;
    }

    // The camera path. With TwoRadii, the radiance at the smaller radii too: the same path (the
    // same samples, the same transmittance estimates) with the surface estimate and every beam
    // estimate gathered at kSmallerRadiusAreaRatio of their disks' areas; the first result's
    // floats are Li()'s.
    template <bool TwoRadii>
    TwoRadiiRadiance trace(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
                           const PassData* passData) const {
        const PhotonPassData& data = photonPassData(passData);
        Color3f result(0.0f), smallerResult(0.0f), throughput(1.0f);
        float etaScale = 1.0f;
        // Unit direction: media measure distances in world units.
        const float length = cameraRay.d.norm();
        if (!(length > 0.0f)) return {result, smallerResult};
        Ray3f ray(cameraRay.o, cameraRay.d / length, cameraRay.mint * length,
                  cameraRay.maxt * length);
        const Medium* medium = scene.camera()->medium();
        Eigen::AlignedBox3f bounds = m_mediaBox;
        bounds.extend(cameraRay.o);
        thread_local StraightPath line;
        for (int depth = 0;;) {
            Intersection its;
            const bool hit = walkStraight(scene, ray, bounds, medium, line, its);
            // Beam estimate and emission of null surfaces along the line, then its transmittance.
            const TwoRadiiRadiance along =
                lineRadiance<TwoRadii>(data, line, hit ? &its : nullptr, sampler);
            result += throughput * along.atPassRadius;
            if constexpr (TwoRadii) smallerResult += throughput * along.atSmallerRadius;
            throughput *= line.transmittance;
            if (!hit && !throughput.isBlack()) {
                // The delta path left the scene (and the media box): the environment counts fully.
                const Color3f escaped = throughput * escapedRadiance(scene, ray.o, ray.d);
                result += escaped;
                if constexpr (TwoRadii) smallerResult += escaped;
            }
            if (!hit || throughput.isBlack()) break;

            const Vector3f dir = ray.d;
            const Color3f emitted = throughput * emittedRadiance(its.p - its.t * dir, dir, its);
            result += emitted;
            if constexpr (TwoRadii) smallerResult += emitted;
            const BSDF& bsdf = *its.mesh->bsdf();
            const Vector3f wi = its.toLocal(-dir);
            if (bsdf.isDiffuse()) {
                if constexpr (TwoRadii) {
                    const TwoRadiiRadiance reflected =
                        reflectedRadianceTwoRadii(data, its, bsdf, wi);
                    result += throughput * reflected.atPassRadius;
                    smallerResult += throughput * reflected.atSmallerRadius;
                } else {
                    result += throughput * reflectedRadiance(data, its, bsdf, wi);
                }
                if (samplesDirectLight()) {
                    const ScatteringVertex vertex =
                        ScatteringVertex::onSurface(its, bsdf, dir, medium);
                    const Color3f direct =
                        throughput * sampleLightThroughMedia(scene, sampler, vertex, bounds, false);
                    result += direct;
                    if constexpr (TwoRadii) smallerResult += direct;
                }
                break;
            }
            const auto next = followDeltaChain(its, wi, depth++, sampler, throughput, etaScale);
            if (!next) break;
            const Vector3f wo = next->normalized();
            medium = its.mesh->mediumTowards(its, wo, medium);
            ray = Ray3f(its.p, wo);
        }
        return {result, smallerResult};
    }

    std::shared_ptr<const PhotonPassData> tracePass(const Scene& scene, uint64_t seed,
                                                    uint64_t pass) const override {
        const uint64_t volumeCount = m_hasMedia ? m_volumeCount : 0;
        TracedPhotons traced = tracePhotonsThroughMedia(scene, seed, pass, m_surfaceCount,
                                                        volumeCount, directPhotons());
        auto data = std::make_shared<PhotonPassData>();
        setSurfaceMap(*data, std::move(traced.surface), traced.emitted, pass);
        // kNN radii: the search bound stays as given, each radius shrinks (passRadiusScale).
        const float volumeRadius =
            m_volumeK > 0 ? m_volumeRadius : passRadius(m_volumeRadius, pass);
        if (!traced.volume.empty())
            data->volume =
                m_volumeK > 0
                    ? VolumePhotonMap(std::move(traced.volume), std::move(traced.volumeMedia),
                                      static_cast<size_t>(m_volumeK), volumeRadius,
                                      passRadiusScale(pass))
                    : VolumePhotonMap(std::move(traced.volume), std::move(traced.volumeMedia),
                                      volumeRadius);
        data->volumeEmitted = traced.volumeEmitted;
        data->volumePowerScale =
            traced.volumeEmitted > 0 ? 1.0 / static_cast<double>(traced.volumeEmitted) : 0.0;
        data->volumeRadius = volumeRadius;
        return data;
    }

    // A straight piece of a camera path: from `origin` along `direction` through null
    // (index-matched) boundaries, which change the medium but not the direction, to the first
    // other surface, or to where the ray leaves the media box. t is measured from `origin`.
    struct StraightPath {
        struct Span {
            float start, end;
            const Medium* medium;
        };
        struct Emission {
            float t;
            Color3f radiance;
        };
        Point3f origin;
        Vector3f direction;
        float end = 0.0f;
        std::vector<Span> spans;          // the participating media along it, by increasing t
        std::vector<Emission> emissions;  // emitting null surfaces crossed
        std::vector<SphereHit> hits;      // scratch for the beam query
        Color3f transmittance;            // over [0, end], set by lineRadiance()
    };

    // Walks `ray` through null boundaries (updating `medium`), filling `line`; returns whether it
    // ends at a surface, then `its` (with its.t measured from the last crossing).
    static bool walkStraight(const Scene& scene, const Ray3f& ray,
                             const Eigen::AlignedBox3f& bounds, const Medium*& medium,
                             StraightPath& line, Intersection& its) {
        line.origin = ray.o;
        line.direction = ray.d;
        line.spans.clear();
        line.emissions.clear();
        float base = 0.0f;  // t of the current piece's origin
        Ray3f piece = ray;
        for (;;) {
            const bool hit = scene.rayIntersect(piece, its);
            const float end = hit ? its.t : std::min(piece.maxt, exitDistance(bounds, piece));
            if (isParticipating(medium)) line.spans.push_back({base, base + end, medium});
            line.end = base + end;
            if (!hit || !its.mesh->bsdf()->isNull()) return hit;
            const Color3f emitted = emittedRadiance(piece.o, piece.d, its);
            if (!emitted.isBlack()) line.emissions.push_back({base + its.t, emitted});
            medium = its.mesh->mediumTowards(its, piece.d, medium);
            base += its.t;
            piece = Ray3f(its.p, piece.d, Epsilon, piece.maxt - its.t);
        }
    }

    // The beam radiance estimate along the whole straight line, plus the emission of the null
    // surfaces on it, each times the transmittance from the line's origin; sets
    // line.transmittance to the whole line's. One query over [0, end] finds every photon sphere
    // the line crosses, whichever medium the photon scattered in (its own phase function
    // applies): a photon near a boundary is found from either side, so no energy is lost where a
    // medium's boundary cuts the photons' discs. Photons are visited by increasing t (ties by
    // index), in an order fixed by the photon array alone, so that one transmittance walk, which
    // multiplies independent unbiased estimates of consecutive pieces, serves them all.
    //
    // No light leaks through walls: photons whose closest point lies beyond `end` are out by the
    // query's clip, but a line meeting a wall obliquely passes photons just behind it at closest
    // points before `end`. When a surface ends the line (`wall`), photons on the far side of its
    // tangent plane are left out too.
    //
    // With TwoRadii, also the same at the smaller radii: each photon's sphere shrunk to
    // kSmallerRadiusAreaRatio of its disk's area, from the same query (the smaller spheres the
    // line crosses are among the larger ones) and the same transmittance walk.
    template <bool TwoRadii>
    TwoRadiiRadiance lineRadiance(const PhotonPassData& data, StraightPath& line,
                                  const Intersection* wall, Sampler& sampler) const {
        line.transmittance = Color3f(1.0f);
        if (line.spans.empty() && line.emissions.empty()) return {Color3f(0.0f), Color3f(0.0f)};
        Color3f& transmittance = line.transmittance;
        size_t span = 0;
        float walked = 0.0f;
        auto walkTo = [&](float t) {
            while (walked < t && span < line.spans.size()) {
                const StraightPath::Span& s = line.spans[span];
                const float from = std::max(walked, s.start), to = std::min(t, s.end);
                if (to > from && !transmittance.isBlack())
                    transmittance *= s.medium->transmittance(
                        Ray3f(line.origin + from * line.direction, line.direction), to - from,
                        sampler);
                if (t < s.end) break;
                walked = s.end;
                ++span;
            }
            walked = std::max(walked, t);
        };

        line.hits.clear();
        if (!line.spans.empty() && !data.volume.empty())
            data.volume.crossedBy(line.origin, line.direction, 0.0f, line.end, line.hits);
        // crossedBy() returns the photons by increasing t, ties by index.
        const Normal3f wallNormal = wall ? wall->geometricNormal() : Normal3f::UnitZ();
        const float cameraSide = wall ? (line.origin - wall->p).dot(wallNormal) : 0.0f;
        const Photons& photons = data.volume.photons();
        Color3f beam(0.0f), smallerBeam(0.0f), emitted(0.0f);
        size_t next = 0;
        auto emitUpTo = [&](float t) {
            for (; next < line.emissions.size() && line.emissions[next].t <= t; ++next) {
                walkTo(line.emissions[next].t);
                emitted += transmittance * line.emissions[next].radiance;
            }
        };
        for (const SphereHit& hit : line.hits) {
            emitUpTo(hit.t);
            const Photon& photon = photons[hit.index];
            const Medium* medium = data.volume.medium(hit.index);
            if (!medium) continue;
            if (wall && (photon.position - wall->p).dot(wallNormal) * cameraSide < 0.0f) continue;
            walkTo(hit.t);
            if (transmittance.isBlack()) break;
            const float r = data.volume.radius(hit.index);
            const float phase = medium->phase().eval(-line.direction, photon.direction);
            beam += transmittance * photon.power *
                    static_cast<float>(phase / (M_PI * double(r) * double(r)));
            if constexpr (TwoRadii) {
                // The photon's offset from the line at its closest point t_i (as the query
                // measures it, segmentCrossesSphere()).
                const Vector3f offset = (photon.position - line.origin) - hit.t * line.direction;
                const double smallerRadius2 = double(r) * double(r) * kSmallerRadiusAreaRatio;
                if (double(offset.squaredNorm()) < smallerRadius2)
                    smallerBeam += transmittance * photon.power *
                                   static_cast<float>(phase / (M_PI * smallerRadius2));
            }
        }
        emitUpTo(Infinity);
        walkTo(line.end);
        const float powerScale = static_cast<float>(data.volumePowerScale);
        if constexpr (TwoRadii)
            return {beam * powerScale + emitted, smallerBeam * powerScale + emitted};
        else
            return {beam * powerScale + emitted, Color3f(0.0f)};
    }

    uint64_t m_surfaceCount = 0, m_volumeCount = 0;
    float m_volumeRadius = 0.0f;
    bool m_volumeRadiusGiven = false;
    int m_volumeK = 0;
    Eigen::AlignedBox3f m_mediaBox;
    bool m_hasMedia = false;
};

ALPHORN_REGISTER(Integrator, "volumetric_photonmapper", VolumetricPhotonMapper);

}  // namespace alphorn
