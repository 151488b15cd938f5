// What bdpt and vcm share: light subpaths traced per pass as pass data, the camera subpath of
// each sample, every connection strategy (emission hits, next-event estimation, connections of
// inner vertices, light tracing to the camera), vertex merging, and their MIS weights
// (vcm_mis.h). The two plugins differ only in which strategies they enable.
//
// The pass model: a pass's light subpaths are a pure function of (scene, seed, pass), like a
// photon map: path i draws from the sampler stream (seed, pass, i, Photon) and the paths are
// traced in fixed chunks and concatenated in path order. Light tracing (a light vertex joined to
// the camera) lands anywhere on the image, so preparePass() also splats those contributions into
// a per-pass light image of exact fixed-point sums; every unit adds the part of it on its own
// tile (addPassSplats). Each pixel's share is then added by exactly the one unit that owns the
// pixel, whatever the tiling, threads or workers, and the film stays byte-identical. A camera
// sample connects to one light path chosen uniformly with one number of its own stream, and
// merges with the light vertices of all paths of the pass (a hashed grid, as the photon maps).
//
// Surfaces only: a scene with participating media is refused. Light tracing needs a pinhole
// camera (a physical camera with apertureRadius 0).
#pragma once

#include "common/core/dpdf.h"
#include "common/core/frame.h"
#include "common/integrator/integrator.h"
#include "common/integrator/vcm_mis.h"
#include "common/photon/photon.h"
#include "common/photon/photon_hash_grid.h"
#include "common/render/film.h"

#include <unordered_map>

namespace alphorn {

class BSDF;
class Emitter;

// A vertex of a light or camera subpath.
struct PathVertex {
    Point3f p = Point3f::Zero();
    Frame shFrame;                   // shading frame (surfaces, area lights)
    Normal3f ng = Normal3f::Zero();  // geometric normal; zero at a point light or the camera
    Point2f uv = Point2f::Zero();
    const BSDF* bsdf = nullptr;              // null on an emitter (light vertex 0) and the camera
    const Emitter* emitter = nullptr;        // light vertex 0 only
    Vector3f toPrevious = Vector3f::Zero();  // unit world direction to the previous vertex
    // Light vertex 0: 1 / (selection pdf * position pdf); the emission is evaluated per
    // connection. Others: the subpath's weight arriving here (emission included for light
    // paths), without the cosine at this vertex.
    Color3f beta = Color3f(0.0f);
    double pdfForward = 1.0;  // area density of this subpath producing this vertex
    double pdfReverse = 1.0;  // area density of the other side producing it (set one step later)
    bool delta = false;       // delta BSDF, or (light vertex 0) a point-like light

    bool connectible() const { return !(bsdf && delta); }
};

struct BidirectionalPassData : PassData {
    uint64_t lightPathCount = 0;
    std::vector<PathVertex> lightVertices;  // all light subpaths of the pass, in path order
    std::vector<uint64_t> lightPathStart;   // path i holds vertices [start[i], start[i + 1])
    float mergeRadius = 0.0f;
    // Non-delta light vertices 1.. as photons for the merge grid, which reads their positions;
    // a merge reads the vertex itself through mergeVertex.
    Photons mergePoints;
    std::vector<uint32_t> mergeVertex;  // index into lightVertices of each merge point
    std::vector<uint32_t> mergeDepth;   // its index in its light subpath
    PhotonHashGrid mergeGrid;
    FilmBlock lightImage;                 // light tracing's exact sums over the whole image
    std::vector<Vector2i> invalidSplats;  // pixels of rejected light-tracing values
};

class BidirectionalIntegrator : public Integrator {
  public:
    enum class Kind { Bdpt, Vcm };

    void preprocess(const Scene& scene) override;
    std::shared_ptr<const PassData> preparePass(const Scene& scene, uint64_t seed,
                                                uint64_t pass) const override;
    std::optional<RadiusSchedule> radiusSchedule() const override;
    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& ray,
               const PassData* pass) const override;
    // vcm with merging: the second image merges within r_i / sqrt(2) of the same camera
    // vertices, from the same query, each merge weighted as in the image (see radiance()).
    bool estimatesBiasWithTwoRadii() const override {
        return m_kind == Kind::Vcm && m_strategies.merging;
    }
    TwoRadiiRadiance LiTwoRadii(const Scene& scene, Sampler& sampler, const Ray3f& ray,
                                const PassData* pass) const override;
    void addPassSplats(const PassData* pass, int x0, int y0, int x1, int y1,
                       FilmBlock& out) const override;
    bool hasPassSplats() const override { return m_strategies.lightTracing; }
    std::string toString() const override;

    const MisStrategies& strategies() const { return m_strategies; }

  protected:
    BidirectionalIntegrator(const PropertyList& props, Kind kind);

  private:
    struct LightChoice {
        const Emitter* emitter = nullptr;
        float pdf = 0.0f;
    };
    LightChoice chooseLight(float u) const;
    float lightSelectionPdf(const Emitter* emitter) const;
    // The light vertex 0 drawn from two numbers: position on an area light or the light's point.
    bool sampleLightVertex(const LightChoice& light, const Point2f& u, PathVertex& v) const;
    // Emitted radiance (area) or intensity (point-like) leaving light vertex `v` along unit `d`,
    // with the cosine at the light (1 for point-like lights).
    Color3f emission(const PathVertex& v, const Vector3f& d, float& cosLight) const;
    // Solid-angle density of the light path's first direction `d` from light vertex `v`.
    double emissionDirectionPdf(const PathVertex& v, const Vector3f& d) const;

    // `passStrategies`: the strategies with the pass's merge area, for the MIS weights.
    void traceLightPath(const Scene& scene, Sampler& sampler, const MisStrategies& passStrategies,
                        std::vector<PathVertex>& out,
                        std::vector<std::pair<Point2f, Color3f>>& splats) const;
    // Light tracing of light vertex `index` of the path `path` (vertices path[0..index]).
    void connectToCamera(const Scene& scene, const MisStrategies& passStrategies,
                         const PathVertex* path, size_t index,
                         std::vector<std::pair<Point2f, Color3f>>& splats) const;

    // Why the light path count's pass cannot fit in this machine's memory (at least the vertex
    // on the light per path), beginning with `what`; empty when it can.
    std::string lightPathMemoryProblem(const std::string& what) const;
    double mergeArea(float radius) const;
    // Li(); when `atSmallerRadius` is given, also the radiance with every merge gathered within
    // r_i / sqrt(2) instead of r_i (normalised by the smaller disk's area) and everything else,
    // the merges' MIS weights included, as in the image.
    Color3f radiance(const Scene& scene, Sampler& sampler, const Ray3f& ray, const PassData* pass,
                     Color3f* atSmallerRadius) const;

    Kind m_kind;
    int m_maxDepth;             // bounces, -1 unlimited
    int m_lightPathCountGiven;  // 0: the pixel count
    uint64_t m_lightPathCount = 1;
    float m_radius = 0.0f;
    bool m_radiusGiven = false;
    double m_alpha = 0.75;
    bool m_lightTracingOnly = false;
    MisStrategies m_strategies;

    const Scene* m_scene = nullptr;
    DiscretePDF m_lightPdf;
    std::unordered_map<const Emitter*, size_t> m_lightIndex;
};

}  // namespace alphorn
