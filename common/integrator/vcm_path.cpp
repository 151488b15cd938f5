#include "common/integrator/vcm_path.h"

#include "common/bsdf/bsdf.h"
#include "common/core/system_memory.h"
#include "common/core/warp.h"
#include "common/emitter/delta_light.h"
#include "common/integrator/direct.h"
#include "common/photon/radius_schedule.h"
#include "common/scene/scene.h"

#include <absl/strings/str_format.h>
#include <tbb/parallel_for.h>

namespace alphorn {

namespace {

// Light paths per task. Fixed, so that the concatenated output never depends on threads.
constexpr uint64_t kChunk = 2048;

using Splats = std::vector<std::pair<Point2f, Color3f>>;

BSDFQueryRecord bsdfQuery(const PathVertex& v, const Vector3f& wiWorld, const Vector3f& woWorld) {
    BSDFQueryRecord rec(v.shFrame.toLocal(wiWorld), v.shFrame.toLocal(woWorld),
                        Measure::SolidAngle);
    rec.uv = v.uv;
    rec.p = v.p;
    return rec;
}

// f(wi, wo) at a surface vertex (wi towards the camera side, wo towards the light side).
Color3f evalBSDF(const PathVertex& v, const Vector3f& wi, const Vector3f& wo) {
    return v.bsdf->eval(bsdfQuery(v, wi, wo));
}
// Solid-angle density of sampling wo given wi.
double pdfBSDF(const PathVertex& v, const Vector3f& wi, const Vector3f& wo) {
    return v.bsdf->pdf(bsdfQuery(v, wi, wo));
}

// Converts a solid-angle density at `from` towards `to` into an area density at `to`. Vertices
// without a normal (point lights, the camera) take none; a density of a delta direction is the
// placeholder 1.
double toArea(double pdfSolidAngle, const PathVertex& from, const PathVertex& to) {
    const Vector3f d = to.p - from.p;
    const double dist2 = double(d.squaredNorm());
    if (!(dist2 > 0.0)) return 0.0;
    double cosine = 1.0;
    if (!to.ng.isZero()) cosine = std::abs(double(to.ng.dot(d))) / std::sqrt(dist2);
    return pdfSolidAngle * cosine / dist2;
}

PathVertex surfaceVertex(const Intersection& its, const Vector3f& toPrevious, const Color3f& beta) {
    PathVertex v;
    v.p = its.p;
    v.shFrame = its.shFrame;
    v.ng = its.geometricNormal();
    v.uv = its.uv;
    v.bsdf = its.mesh->bsdf();
    v.toPrevious = toPrevious;
    v.beta = beta;
    v.delta = !v.bsdf->isDiffuse();
    return v;
}

// Fills `out` with the MIS view of light vertices light[0..s) and camera vertices
// camera[0..t) (camera[0] is the camera), joined in the order x_0 = light[0] ... x_k =
// camera[0]. Callers then replace the densities that the joining changes.
void misPath(const PathVertex* light, size_t s, const PathVertex* camera, size_t t,
             std::vector<MisVertex>& out) {
    out.resize(s + t);
    for (size_t i = 0; i < s; ++i)
        out[i] = MisVertex{light[i].pdfForward, light[i].pdfReverse, light[i].connectible()};
    for (size_t j = 0; j < t; ++j)
        out[s + t - 1 - j] =
            MisVertex{camera[j].pdfReverse, camera[j].pdfForward, camera[j].connectible()};
}

}  // namespace

BidirectionalIntegrator::BidirectionalIntegrator(const PropertyList& props, Kind kind)
    : m_kind(kind) {
    m_maxDepth = props.getInteger("maxDepth", -1);
    if (m_maxDepth < -1) props.fail("\"maxDepth\" must be -1 (unlimited) or >= 0");
    m_lightPathCountGiven = props.getInteger("lightPathCount", 0);
    if (props.has("lightPathCount") && m_lightPathCountGiven <= 0)
        props.fail("\"lightPathCount\" (light paths per pass) must be positive, got %d",
                   m_lightPathCountGiven);
    if (m_lightPathCountGiven > 0) {
        const std::string problem = lightPathMemoryProblem("\"lightPathCount\"");
        if (!problem.empty()) props.failBeyondLimit("%s", problem);
    }
    m_lightTracingOnly = props.getBoolean("lightTracingOnly", false);
    bool connections = true, merging = false;
    if (kind == Kind::Vcm) {
        m_radiusGiven = props.has("radius");
        m_radius = props.getFloat("radius", 0.0f);
        if (m_radiusGiven && !(m_radius > 0.0f && std::isfinite(m_radius)))
            props.fail(
                "\"radius\" (the first pass's merge radius) must be positive and finite, "
                "got %g",
                m_radius);
        const float alpha = props.getFloat("alpha", 0.75f);
        if (!isValidRadiusAlpha(alpha))
            props.fail("\"alpha\" must be in (0, 1) (the radius schedule's parameter), got %g",
                       alpha);
        m_alpha = alpha;
        connections = props.getBoolean("connections", true);
        merging = props.getBoolean("merging", true);
        if (!connections && !merging && !m_lightTracingOnly)
            props.fail("\"connections\" and \"merging\" are both off: no strategy is left");
    }
    if (m_lightTracingOnly) {
        m_strategies.hits = m_strategies.connections = m_strategies.merging = false;
        m_strategies.lightTracing = true;
    } else {
        m_strategies.hits = true;  // emitters seen by camera paths
        m_strategies.connections = connections;
        m_strategies.lightTracing = connections;
        m_strategies.merging = merging;
    }
}

std::string BidirectionalIntegrator::lightPathMemoryProblem(const std::string& what) const {
    const uint64_t count =
        m_lightPathCountGiven > 0 ? uint64_t(m_lightPathCountGiven) : m_lightPathCount;
    // Every light path keeps its first vertex (on the light), its start in the vertex array and
    // its length while the chunks are joined; paths that bounce keep a vertex per bounce more.
    const uint64_t perPath = sizeof(PathVertex) + 2 * sizeof(uint64_t);
    const uint64_t bytes = count * perPath;
    const uint64_t memory = physicalMemoryBytes();
    if (bytes <= memory) return {};
    return absl::StrFormat(
        "%s of %u light paths needs at least %s per pass (%u bytes per path for its vertex on the "
        "light; each bounce adds %zu), more than this machine's %s of memory",
        what, count, formatBytes(bytes), perPath, sizeof(PathVertex), formatBytes(memory));
}

void BidirectionalIntegrator::preprocess(const Scene& scene) {
    const char* name = m_kind == Kind::Vcm ? "vcm" : "bdpt";
    if (scene.camera()->medium())
        fail(
            "%s renders surfaces only, and the camera sits in a medium: use volume_path_mis or "
            "volumetric_photonmapper for scenes with participating media",
            name);
    if (const Mesh* mesh = scene.findMesh([](const Mesh& m) { return m.hasMediumInterface(); }))
        fail(
            "%s renders surfaces only, and %s bounds a medium: use volume_path_mis or "
            "volumetric_photonmapper for scenes with participating media",
            name, mesh->source());
    if (m_strategies.lightTracing) {
        const std::string refusal = scene.camera()->lightTracingRefusal();
        if (!refusal.empty()) fail("%s traces light to the camera, but %s", name, refusal);
    }
    const Vector2i size = scene.camera()->outputSize();
    m_lightPathCount = m_lightPathCountGiven > 0 ? uint64_t(m_lightPathCountGiven)
                                                 : uint64_t(size.x()) * uint64_t(size.y());
    m_strategies.lightPathCount = double(m_lightPathCount);
    if (m_lightPathCountGiven == 0) {
        const std::string problem =
            lightPathMemoryProblem("the default \"lightPathCount\" (the pixel count)");
        if (!problem.empty()) failBeyondLimit("%s", problem);
    }
    if (!m_radiusGiven) {
        // The photon mapper's default: 1/500 of the scene's diagonal.
        const float diagonal = scene.bounds().isEmpty() ? 1.0f : scene.bounds().diagonal().norm();
        m_radius = diagonal / 500.0f;
        if (m_strategies.merging && !(m_radius > 0.0f && std::isfinite(m_radius)))
            fail("cannot derive a merge radius from the scene's bounds; give \"radius\"");
    }
    // Lights are chosen in proportion to their power, for light paths and next-event
    // estimation alike (the MIS weights need one density of the light vertex).
    m_lightPdf.clear();
    m_lightIndex.clear();
    for (size_t i = 0; i < scene.emitters().size(); ++i) {
        const Emitter* emitter = scene.emitters()[i].get();
        // Light paths from infinity (a disk of light vertices, connections with no distance)
        // are not implemented: refused rather than rendered wrong.
        if (emitter->isInfinite())
            fail("%s does not support lights at infinity (%s); use path_mis or volume_path_mis",
                 name, emitter->toString());
        if (!emitter->isDelta() && !emitter->mesh())
            fail("%s supports area emitters and point-like lights only", name);
        m_lightPdf.append(std::max(0.0, double(emitter->power().mean())));
        m_lightIndex[emitter] = i;
    }
    m_lightPdf.normalize();
    m_scene = &scene;
}

std::optional<RadiusSchedule> BidirectionalIntegrator::radiusSchedule() const {
    if (!m_strategies.merging) return std::nullopt;
    return RadiusSchedule{m_radius, m_alpha};
}

double BidirectionalIntegrator::mergeArea(float radius) const {
    return M_PI * double(radius) * double(radius);
}

BidirectionalIntegrator::LightChoice BidirectionalIntegrator::chooseLight(float u) const {
    LightChoice choice;
    if (m_lightPdf.size() == 0 || !(m_lightPdf.sum() > 0.0)) return choice;
    const size_t index = m_lightPdf.sample(u);
    choice.emitter = m_scene->emitters()[index].get();
    choice.pdf = m_lightPdf[index];
    return choice;
}

float BidirectionalIntegrator::lightSelectionPdf(const Emitter* emitter) const {
    const auto it = m_lightIndex.find(emitter);
    return it == m_lightIndex.end() ? 0.0f : m_lightPdf[it->second];
}

bool BidirectionalIntegrator::sampleLightVertex(const LightChoice& light, const Point2f& u,
                                                PathVertex& v) const {
    if (!light.emitter || !(light.pdf > 0.0f)) return false;
    v = PathVertex();
    v.emitter = light.emitter;
    if (const auto* point = dynamic_cast<const DeltaPositionLight*>(light.emitter)) {
        v.p = point->position();
        v.delta = true;
        v.pdfForward = light.pdf;  // the position is a delta: placeholder 1
    } else {
        const SurfaceSample s = light.emitter->mesh()->sampleSurface(u);
        if (!(s.pdf > 0.0f)) return false;
        v.p = s.p;
        v.ng = s.n;
        v.shFrame = Frame(s.n);
        v.pdfForward = double(light.pdf) * double(s.pdf);
    }
    v.beta = Color3f(static_cast<float>(1.0 / v.pdfForward));
    return true;
}

Color3f BidirectionalIntegrator::emission(const PathVertex& v, const Vector3f& d,
                                          float& cosLight) const {
    if (const auto* point = dynamic_cast<const DeltaPositionLight*>(v.emitter)) {
        cosLight = 1.0f;
        return point->intensity(d);
    }
    cosLight = v.ng.dot(d);
    if (!(cosLight > 0.0f)) return Color3f(0.0f);
    // The area light's one-sided radiance, seen from a point along d.
    EmitterQueryRecord rec(v.p + d, v.p, v.ng);
    rec.wi = -d;
    return v.emitter->eval(rec);
}

double BidirectionalIntegrator::emissionDirectionPdf(const PathVertex& v, const Vector3f& d) const {
    if (const auto* point = dynamic_cast<const DeltaPositionLight*>(v.emitter)) {
        // Point-like lights emit their photons by their own sampling; the MIS weights use the
        // intensity's share of the power, which is that sampling's density for point and spot
        // lights. Any density used consistently by all strategies keeps the weights summing
        // to one, so the estimate stays unbiased where it differs (the projector's floor).
        const double power = double(point->power().mean());
        return power > 0.0 ? double(point->intensity(d).mean()) / power : 0.0;
    }
    return std::max(0.0, double(v.ng.dot(d))) * InvPi;
}

void BidirectionalIntegrator::connectToCamera(const Scene& scene,
                                              const MisStrategies& passStrategies,
                                              const PathVertex* path, size_t index,
                                              Splats& splats) const {
    const PathVertex& y = path[index];
    if (!y.connectible()) return;
    // A point light is never seen by camera rays either; an emitter camera paths can hit is
    // left to them (misWeight gives this strategy nothing then: see vcm_mis.cpp), so neither is
    // projected and shaded here only to be weighted zero.
    if (index == 0 && (y.delta || passStrategies.hits)) return;
    const size_t edges = index + 1;
    if (m_maxDepth >= 0 && edges > size_t(m_maxDepth) + 1) return;
    const Camera& camera = *scene.camera();
    const auto projection = camera.project(y.p);
    if (!projection) return;
    Vector3f toCamera = projection->position - y.p;
    const float dist2 = toCamera.squaredNorm();
    if (!(dist2 > 0.0f)) return;
    const float dist = std::sqrt(dist2);
    toCamera /= dist;
    Color3f f;
    if (index == 0) {
        float cosLight;
        f = emission(y, toCamera, cosLight);
    } else {
        f = evalBSDF(y, toCamera, y.toPrevious);
    }
    if (f.isBlack()) return;
    const double cosGeometric = std::abs(double(y.ng.dot(toCamera)));
    // The camera's density of producing y: one sample per unit of raster area.
    const double cameraPdf = double(projection->rasterPerSolidAngle) * cosGeometric / dist2;
    if (!(cameraPdf > 0.0)) return;

    thread_local std::vector<MisVertex> mis;
    misPath(path, index + 1, nullptr, 0, mis);
    mis.push_back(MisVertex{1.0, 1.0, true});  // the camera
    mis[index].pdfFromCamera = cameraPdf;
    if (index >= 1) {
        const PathVertex& previous = path[index - 1];
        mis[index - 1].pdfFromCamera =
            previous.delta && index - 1 == 0
                ? 1.0
                : toArea(pdfBSDF(y, toCamera, y.toPrevious), y, previous);
    }
    MisStrategies strategies = passStrategies;
    strategies.emitterHittable = !path[0].delta;
    const double weight =
        misWeight(mis.data(), mis.size(), strategies, {MisStrategy::Kind::Connection, int(edges)});
    if (!(weight > 0.0)) return;

    if (scene.rayOccluded(Ray3f(y.p, toCamera, Epsilon, dist * (1.0f - 1e-4f)))) return;
    const Color3f value =
        y.beta * f * static_cast<float>(cameraPdf * weight / double(m_lightPathCount));
    splats.emplace_back(projection->raster, value);
}

void BidirectionalIntegrator::traceLightPath(const Scene& scene, Sampler& sampler,
                                             const MisStrategies& passStrategies,
                                             std::vector<PathVertex>& out, Splats& splats) const {
    const size_t start = out.size();
    const LightChoice light = chooseLight(sampler.next1D());
    const Point2f positionSample = sampler.next2D();
    const Point2f directionSample = sampler.next2D();
    PathVertex y0;
    if (!sampleLightVertex(light, positionSample, y0)) return;

    // The first direction and the weight it carries.
    Vector3f direction;
    Color3f beta;
    double directionPdf;
    if (y0.delta) {
        Ray3f ray;
        const Color3f flux = light.emitter->samplePhoton(ray, positionSample, directionSample);
        direction = ray.d.normalized();
        beta = flux / light.pdf;
        directionPdf = emissionDirectionPdf(y0, direction);
    } else {
        const Vector3f local = warp::squareToCosineHemisphere(directionSample);
        direction = y0.shFrame.toWorld(local);
        directionPdf = double(local.z()) * InvPi;
        float cosLight;
        const Color3f le = emission(y0, direction, cosLight);
        beta = le * static_cast<float>(double(cosLight) / (y0.pdfForward * directionPdf));
    }
    out.push_back(y0);
    if (m_strategies.lightTracing) connectToCamera(scene, passStrategies, &out[start], 0, splats);
    if (beta.isBlack() || !beta.allFinite() || !(directionPdf > 0.0)) return;

    // Light vertex i serves paths of at least i + 1 segments (light tracing).
    const size_t maxEdges =
        m_maxDepth < 0 ? std::numeric_limits<size_t>::max() : size_t(m_maxDepth) + 1;
    Color3f throughput(1.0f);  // relative to the emitted weight, for Russian roulette
    bool previousDelta = false;
    Ray3f ray(y0.p, direction);
    for (size_t index = 1; index + 1 <= maxEdges; ++index) {
        Intersection its;
        if (!scene.rayIntersect(ray, its)) return;
        const Vector3f dir = ray.d.normalized();
        // Flux arrives through the geometric surface, radiance is scattered about the shading
        // normal: the ratio of the two cosines of the arrival (1 on flat-shaded meshes) turns
        // the one into the other, as path tracing's BSDF weights (Veach's adjoint BSDF).
        PathVertex v = surfaceVertex(its, -dir, beta);
        const float cosGeometric = std::abs(v.ng.dot(dir));
        const float arrival =
            cosGeometric > 0.0f ? std::abs(its.shFrame.n.dot(dir)) / cosGeometric : 0.0f;
        v.beta = beta * arrival;
        v.pdfForward = previousDelta ? 1.0 : toArea(directionPdf, out.back(), v);
        out.push_back(v);
        if (!v.delta && m_strategies.lightTracing)
            connectToCamera(scene, passStrategies, &out[start], index, splats);
        if (index + 2 > maxEdges) return;

        BSDFQueryRecord rec(v.shFrame.toLocal(-dir));
        rec.uv = v.uv;
        rec.p = v.p;
        Color3f weight = v.bsdf->sample(rec, sampler.next2D());
        if (weight.isBlack() || !weight.allFinite()) return;
        // Sampling weights are written for radiance, which refraction scales by 1/eta²; light
        // paths carry importance-transported flux, which it does not (as photons).
        weight *= rec.eta * rec.eta;
        const bool discrete = rec.measure == Measure::Discrete;
        const Vector3f next = its.toWorld(rec.wo).normalized();
        // The next segment leaves through the geometric surface (its area density uses that
        // cosine), the sampling weight holds the shading one.
        const float cosShadingNext = std::abs(Frame::cosTheta(rec.wo));
        if (!(cosShadingNext > 0.0f)) return;
        const float leaving = std::abs(v.ng.dot(next)) / cosShadingNext;
        PathVertex& current = out.back();
        PathVertex& previous = out[out.size() - 2];
        if (discrete || (index == 1 && previous.delta))
            previous.pdfReverse = 1.0;
        else
            previous.pdfReverse = toArea(pdfBSDF(current, next, -dir), current, previous);
        directionPdf = discrete ? 1.0 : pdfBSDF(current, -dir, next);
        if (!discrete && !(directionPdf > 0.0)) return;
        previousDelta = discrete;
        throughput *= weight;
        beta = current.beta * weight * leaving;
        if (index >= 3) {
            const float q = std::min(throughput.maxCoeff(), 0.99f);
            if (!(sampler.next1D() < q)) return;
            throughput /= q;
            beta /= q;
        }
        ray = Ray3f(its.p, next);
    }
}

std::shared_ptr<const PassData> BidirectionalIntegrator::preparePass(const Scene& scene,
                                                                     uint64_t seed,
                                                                     uint64_t pass) const {
    auto data = std::make_shared<BidirectionalPassData>();
    const uint64_t count = m_lightPathCount;
    data->lightPathCount = count;
    if (m_strategies.merging)
        data->mergeRadius = static_cast<float>(progressiveRadius(m_radius, m_alpha, pass));
    // Every strategy's weight counts the merges this pass's radius allows.
    MisStrategies strategies = m_strategies;
    strategies.mergeArea = mergeArea(data->mergeRadius);
    const size_t chunks = size_t((count + kChunk - 1) / kChunk);
    struct Chunk {
        std::vector<PathVertex> vertices;
        std::vector<uint64_t> lengths;
        Splats splats;
    };
    std::vector<Chunk> results(chunks);
    tbb::parallel_for(size_t{0}, chunks, [&](size_t c) {
        std::unique_ptr<Sampler> sampler = scene.sampler()->clone();
        // Filled here and moved in at the end: neighbouring chunks share cache lines, which two
        // threads must not write at every vertex.
        Chunk chunk;
        const uint64_t end = std::min(count, uint64_t(c + 1) * kChunk);
        for (uint64_t i = uint64_t(c) * kChunk; i < end; ++i) {
            sampler->startStream(seed, pass, i, StreamPurpose::Photon);
            const size_t before = chunk.vertices.size();
            traceLightPath(scene, *sampler, strategies, chunk.vertices, chunk.splats);
            chunk.lengths.push_back(chunk.vertices.size() - before);
        }
        results[c] = std::move(chunk);
    });
    size_t total = 0;
    for (const Chunk& chunk : results) total += chunk.vertices.size();
    data->lightVertices.reserve(total);
    data->lightPathStart.reserve(count + 1);
    data->lightPathStart.push_back(0);
    for (Chunk& chunk : results) {
        for (uint64_t length : chunk.lengths)
            data->lightPathStart.push_back(data->lightPathStart.back() + length);
        data->lightVertices.insert(data->lightVertices.end(), chunk.vertices.begin(),
                                   chunk.vertices.end());
        chunk.vertices = {};
    }

    // Light tracing's image: fixed-point sums, so the order of the splats does not matter.
    const Camera& camera = *scene.camera();
    const Vector2i size = camera.outputSize();
    if (m_strategies.lightTracing) {
        data->lightImage = FilmBlock(0, 0, size.x(), size.y(), PassHalves::None);
        for (const Chunk& chunk : results)
            for (const auto& [position, value] : chunk.splats) {
                if (!value.isValid() || value.maxCoeff() > kFixedPointLimit) {
                    data->invalidSplats.emplace_back(
                        std::clamp(int(position.x()), 0, size.x() - 1),
                        std::clamp(int(position.y()), 0, size.y() - 1));
                    continue;
                }
                splatFiltered(data->lightImage, *camera.filter(), position, value,
                              SampleWeight::NotCounted);
            }
    }

    if (m_strategies.merging) {
        for (uint64_t path = 0; path < count; ++path)
            for (uint64_t v = data->lightPathStart[path] + 1; v < data->lightPathStart[path + 1];
                 ++v) {
                const PathVertex& vertex = data->lightVertices[v];
                if (vertex.delta) continue;
                data->mergePoints.push_back(Photon{vertex.p, vertex.toPrevious, vertex.beta});
                data->mergeVertex.push_back(static_cast<uint32_t>(v));
                data->mergeDepth.push_back(static_cast<uint32_t>(v - data->lightPathStart[path]));
            }
        if (!data->mergePoints.empty())
            data->mergeGrid = PhotonHashGrid(data->mergePoints.data(), data->mergePoints.size(),
                                             data->mergeRadius);
    }
    return data;
}

void BidirectionalIntegrator::addPassSplats(const PassData* pass, int x0, int y0, int x1, int y1,
                                            FilmBlock& out) const {
    const auto* data = dynamic_cast<const BidirectionalPassData*>(pass);
    if (!data || data->lightImage.width() == 0) return;
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x)
            if (out.contains(x, y) && data->lightImage.contains(x, y)) {
                out.at(x, y) += data->lightImage.at(x, y);
                // Light tracing is a connection: the smaller radius's image has the same.
                if (out.keepsSmallerRadius())
                    out.smallerRadiusAt(x, y) += data->lightImage.at(x, y);
            }
    for (const Vector2i& pixel : data->invalidSplats)
        if (pixel.x() >= x0 && pixel.x() < x1 && pixel.y() >= y0 && pixel.y() < y1)
            ++out.invalidSamples;
}

Color3f BidirectionalIntegrator::Li(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
                                    const PassData* passData) const {
    return radiance(scene, sampler, cameraRay, passData, nullptr);
}

TwoRadiiRadiance BidirectionalIntegrator::LiTwoRadii(const Scene& scene, Sampler& sampler,
                                                     const Ray3f& cameraRay,
                                                     const PassData* passData) const {
    TwoRadiiRadiance both;
    both.atPassRadius = radiance(scene, sampler, cameraRay, passData, &both.atSmallerRadius);
    return both;
}

// The smaller radius's image keeps every merge's MIS weight at the pass radius r_i and changes
// only the disk: the connections (light tracing's splats included) are the image's, and a merge
// adds its light vertices within r_i / sqrt(2) over the smaller disk's area. Its bias is then
// that of the image with each merge's blur at half the area, half the image's wherever the
// merged light is smooth across the disk, which is what the two radii's factor 2 assumes.
// Rendering at r_i / sqrt(2) outright would also halve the merges' share of the MIS weights
// (merge density n pi r^2 against the connections'): where connections and merges share a path
// the image's bias then falls faster than r^2 and the factor 2 would overstate it.
Color3f BidirectionalIntegrator::radiance(const Scene& scene, Sampler& sampler,
                                          const Ray3f& cameraRay, const PassData* passData,
                                          Color3f* atSmallerRadius) const {
    if (atSmallerRadius) *atSmallerRadius = Color3f(0.0f);
    const auto* data = dynamic_cast<const BidirectionalPassData*>(passData);
    if (!data) fail("%s: no pass data for this pass", toString());
    // One light path per camera sample, chosen uniformly among the pass's paths.
    const uint64_t count = data->lightPathCount;
    const uint64_t choice =
        std::min<uint64_t>(count - 1, static_cast<uint64_t>(double(sampler.next1D()) * count));
    if (m_lightTracingOnly) return Color3f(0.0f);
    const PathVertex* lightPath = data->lightVertices.data() + data->lightPathStart[choice];
    const size_t lightLength =
        size_t(data->lightPathStart[choice + 1] - data->lightPathStart[choice]);

    const size_t maxEdges =
        m_maxDepth < 0 ? std::numeric_limits<size_t>::max() : size_t(m_maxDepth) + 1;
    thread_local std::vector<PathVertex> camera;
    thread_local std::vector<MisVertex> mis;
    camera.clear();
    PathVertex z0;
    z0.p = cameraRay.o;
    camera.push_back(z0);

    const Scene& s = scene;
    MisStrategies passStrategies = m_strategies;
    passStrategies.mergeArea = mergeArea(data->mergeRadius);
    Color3f result(0.0f), beta(1.0f);
    float etaScale = 1.0f;
    bool previousDelta = false;
    double directionPdf = double(s.camera()->rasterPerSolidAngle(cameraRay.d));
    Ray3f ray = cameraRay;
    for (size_t j = 1; j <= maxEdges; ++j) {
        Intersection its;
        if (!s.rayIntersect(ray, its)) break;
        const Vector3f dir = ray.d.normalized();
        {
            PathVertex v = surfaceVertex(its, -dir, beta);
            v.pdfForward = previousDelta ? 1.0 : toArea(directionPdf, camera.back(), v);
            camera.push_back(v);
        }
        const PathVertex& z = camera.back();

        // s = 0: the camera path hits an emitter.
        if (m_strategies.hits && its.mesh->emitter()) {
            const Color3f le = emittedRadiance(camera[j - 1].p, dir, its);
            if (!le.isBlack()) {
                misPath(nullptr, 0, camera.data(), j + 1, mis);
                PathVertex light;
                light.p = z.p;
                light.ng = z.ng;
                light.emitter = its.mesh->emitter();
                mis[0].pdfFromLight =
                    double(lightSelectionPdf(light.emitter)) / double(its.mesh->surfaceArea());
                if (j >= 2)
                    mis[1].pdfFromLight =
                        toArea(emissionDirectionPdf(light, -dir), light, camera[j - 1]);
                MisStrategies strategies = passStrategies;
                strategies.emitterHittable = true;
                const double w = misWeight(mis.data(), mis.size(), strategies,
                                           {MisStrategy::Kind::Connection, 0});
                const Color3f term = beta * le * static_cast<float>(w);
                result += term;
                if (atSmallerRadius) *atSmallerRadius += term;
            }
        }

        if (!z.delta) {
            // s = 1: next-event estimation, with a light vertex of its own.
            const LightChoice light = chooseLight(sampler.next1D());
            const Point2f lightSample = sampler.next2D();
            PathVertex y0;
            if (m_strategies.connections && j + 1 <= maxEdges &&
                sampleLightVertex(light, lightSample, y0)) {
                Vector3f d = y0.p - z.p;
                const float dist2 = d.squaredNorm();
                const float dist = std::sqrt(dist2);
                d /= dist;
                float cosLight;
                const Color3f le = emission(y0, -d, cosLight);
                const Color3f f = evalBSDF(z, z.toPrevious, d);
                if (dist2 > 0.0f && !le.isBlack() && !f.isBlack()) {
                    misPath(&y0, 1, camera.data(), j + 1, mis);
                    mis[0].pdfFromCamera =
                        y0.delta ? 1.0 : toArea(pdfBSDF(z, z.toPrevious, d), z, y0);
                    mis[1].pdfFromLight = toArea(emissionDirectionPdf(y0, -d), y0, z);
                    if (j >= 2)
                        mis[2].pdfFromLight = toArea(pdfBSDF(z, d, z.toPrevious), z, camera[j - 1]);
                    MisStrategies strategies = passStrategies;
                    strategies.emitterHittable = !y0.delta;
                    const double w = misWeight(mis.data(), mis.size(), strategies,
                                               {MisStrategy::Kind::Connection, 1});
                    if (w > 0.0 && !s.rayOccluded(Ray3f(z.p, d, Epsilon, dist - Epsilon))) {
                        const float g = std::abs(z.shFrame.n.dot(d)) * cosLight / dist2;
                        const Color3f term = beta * f * le * y0.beta * (g * static_cast<float>(w));
                        result += term;
                        if (atSmallerRadius) *atSmallerRadius += term;
                    }
                }
            }

            // s >= 2: connections to the chosen light path's vertices 1...
            if (m_strategies.connections)
                for (size_t i = 1; i < lightLength && i + j + 1 <= maxEdges; ++i) {
                    const PathVertex& y = lightPath[i];
                    if (y.delta) continue;
                    Vector3f d = y.p - z.p;
                    const float dist2 = d.squaredNorm();
                    if (!(dist2 > 0.0f)) continue;
                    const float dist = std::sqrt(dist2);
                    d /= dist;
                    const Color3f fz = evalBSDF(z, z.toPrevious, d);
                    if (fz.isBlack()) continue;
                    const Color3f fy = evalBSDF(y, -d, y.toPrevious);
                    if (fy.isBlack()) continue;
                    const size_t sCount = i + 1;
                    misPath(lightPath, sCount, camera.data(), j + 1, mis);
                    mis[sCount - 1].pdfFromCamera = toArea(pdfBSDF(z, z.toPrevious, d), z, y);
                    const PathVertex& yPrevious = lightPath[i - 1];
                    mis[sCount - 2].pdfFromCamera =
                        (i - 1 == 0 && yPrevious.delta)
                            ? 1.0
                            : toArea(pdfBSDF(y, -d, y.toPrevious), y, yPrevious);
                    mis[sCount].pdfFromLight = toArea(pdfBSDF(y, y.toPrevious, -d), y, z);
                    if (j >= 2)
                        mis[sCount + 1].pdfFromLight =
                            toArea(pdfBSDF(z, d, z.toPrevious), z, camera[j - 1]);
                    MisStrategies strategies = passStrategies;
                    strategies.emitterHittable = !lightPath[0].delta;
                    const double w = misWeight(mis.data(), mis.size(), strategies,
                                               {MisStrategy::Kind::Connection, int(sCount)});
                    if (!(w > 0.0)) continue;
                    if (s.rayOccluded(Ray3f(z.p, d, Epsilon, dist * (1.0f - 1e-4f)))) continue;
                    // The shading cosine at z (its BSDF's), the geometric one at y (y.beta
                    // holds the arrival's ratio).
                    const float g = std::abs(z.shFrame.n.dot(d)) * std::abs(y.ng.dot(d)) / dist2;
                    const Color3f term = beta * fz * fy * y.beta * (g * static_cast<float>(w));
                    result += term;
                    if (atSmallerRadius) *atSmallerRadius += term;
                }

            // Merging with the light vertices of every path of the pass near z.
            if (m_strategies.merging && !data->mergePoints.empty()) {
                const float radius = data->mergeRadius;
                const double normalisation = 1.0 / (double(count) * mergeArea(radius));
                const double smallerRadius2 =
                    double(radius) * double(radius) * kSmallerRadiusAreaRatio;
                Color3f merged(0.0f), mergedSmaller(0.0f);
                // One query record for z, its camera-side direction in the local frame once;
                // each light vertex adds only its own direction.
                BSDFQueryRecord rec(z.shFrame.toLocal(z.toPrevious), Vector3f::Zero(),
                                    Measure::SolidAngle);
                rec.uv = z.uv;
                rec.p = z.p;
                MisStrategies strategies = passStrategies;
                data->mergeGrid.forEachWithin(z.p, radius, [&](uint32_t index, float distance2) {
                    const size_t m = data->mergeDepth[index];
                    if (m + j > maxEdges) return;
                    const PathVertex& y = data->lightVertices[data->mergeVertex[index]];
                    rec.wo = z.shFrame.toLocal(y.toPrevious);
                    const Color3f f = z.bsdf->eval(rec);
                    if (f.isBlack()) return;
                    const PathVertex* path = &y - m;
                    misPath(path, m, camera.data(), j + 1, mis);
                    // x_m is z (the camera's vertex), reached by the light path as y.
                    mis[m].pdfFromLight = y.pdfForward;
                    const PathVertex& yPrevious = path[m - 1];
                    mis[m - 1].pdfFromCamera = (m - 1 == 0 && yPrevious.delta)
                                                   ? 1.0
                                                   : toArea(z.bsdf->pdf(rec), z, yPrevious);
                    if (j >= 2) {
                        BSDFQueryRecord reverse(rec.wo, rec.wi, Measure::SolidAngle);
                        reverse.uv = z.uv;
                        reverse.p = z.p;
                        mis[m + 1].pdfFromLight = toArea(z.bsdf->pdf(reverse), z, camera[j - 1]);
                    }
                    strategies.emitterHittable = !path[0].delta;
                    const double w = misWeight(mis.data(), mis.size(), strategies,
                                               {MisStrategy::Kind::Merge, int(m)});
                    const Color3f term = f * y.beta * static_cast<float>(w);
                    merged += term;
                    if (atSmallerRadius && double(distance2) <= smallerRadius2)
                        mergedSmaller += term;
                });
                result += beta * merged * static_cast<float>(normalisation);
                if (atSmallerRadius)
                    *atSmallerRadius += beta * mergedSmaller *
                                        static_cast<float>(normalisation / kSmallerRadiusAreaRatio);
            }
        }

        if (j >= maxEdges) break;
        // Russian roulette from the fourth vertex on, as the path tracers.
        if (j >= 4) {
            const float q = std::min(beta.maxCoeff() * etaScale, 0.99f);
            if (!(sampler.next1D() < q)) break;
            beta /= q;
            camera.back().beta = beta;
        }
        PathVertex& current = camera.back();
        BSDFQueryRecord rec(current.shFrame.toLocal(current.toPrevious));
        rec.uv = current.uv;
        rec.p = current.p;
        const Color3f weight = current.bsdf->sample(rec, sampler.next2D());
        if (weight.isBlack() || !weight.allFinite()) break;
        const bool discrete = rec.measure == Measure::Discrete;
        const Vector3f next = its.toWorld(rec.wo).normalized();
        PathVertex& previous = camera[j - 1];
        if (discrete || j == 1)
            previous.pdfReverse = 1.0;  // the camera itself is never produced by light paths
        else
            previous.pdfReverse =
                toArea(pdfBSDF(current, next, current.toPrevious), current, previous);
        directionPdf = discrete ? 1.0 : pdfBSDF(current, current.toPrevious, next);
        if (!discrete && !(directionPdf > 0.0)) break;
        previousDelta = discrete;
        beta *= weight;
        etaScale *= rec.eta * rec.eta;
        ray = Ray3f(current.p, next);
    }
    return result;
}

std::string BidirectionalIntegrator::toString() const {
    std::string strategies;
    if (m_lightTracingOnly)
        strategies = "light tracing only";
    else if (m_strategies.connections && m_strategies.merging)
        strategies = "connections and merging";
    else if (m_strategies.connections)
        strategies = "connections";
    else
        strategies = "merging";
    return absl::StrFormat(
        "%s (%s, %u light paths per pass%s)", m_kind == Kind::Vcm ? "vcm" : "bdpt", strategies,
        m_lightPathCount,
        m_strategies.merging ? absl::StrFormat(", radius %g, alpha %g", m_radius, m_alpha) : "");
}

}  // namespace alphorn
