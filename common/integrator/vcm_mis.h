// Multiple importance sampling weights of bidirectional path tracing and vertex connection and
// merging (Georgiev et al. 2012; Hachisuka et al. 2012), computed from the densities of a whole
// path so that they can be tested apart from any renderer.
//
// A path x_0 ... x_k has k + 1 vertices: x_0 on an emitter, x_k at the camera. The strategies:
// - connection (s, t), s + t = k + 1, t >= 1: the light subpath x_0 .. x_{s-1} is joined to the
//   camera subpath x_s .. x_k. s = 0 is a camera path hitting an emitter, s = 1 next-event
//   estimation, t = 1 light tracing (a light vertex joined to the camera);
// - merge at m, 1 <= m <= k - 1: a light subpath ending at x_m and a camera subpath ending
//   near it (within the merge radius).
// Each vertex carries the area density with which the light side and the camera side produce
// it. A connection's density is the product of the light-side densities of its light vertices
// and the camera-side densities of its camera vertices; light tracing and merging draw from all
// lightPathCount light paths of a pass, so their densities carry that factor, and merging the
// merge disk's area as well. The weight is the balance heuristic over the strategies enabled
// and possible for the path (no connection at a delta surface, no hit of a point-like light, no
// light tracing of an emitter the camera path can hit directly).
// Densities of vertices produced through a delta bounce are placeholders (1) on both sides: the
// delta factors cancel between the strategies that can produce such a path.
#pragma once

#include <cstddef>

namespace alphorn {

struct MisVertex {
    double pdfFromLight = 1.0;   // area density of the light subpath producing this vertex
    double pdfFromCamera = 1.0;  // area density of the camera subpath producing it
    bool connectible = true;     // false at a delta (mirror, glass) surface
};

struct MisStrategies {
    bool hits = true;          // s = 0
    bool connections = true;   // s >= 1, t >= 2 (next-event estimation included)
    bool lightTracing = true;  // t = 1
    bool merging = false;
    double lightPathCount = 1.0;  // light paths per pass
    double mergeArea = 0.0;       // pi r^2 of the pass's merge radius
    bool emitterHittable = true;  // false when x_0 is a point-like (delta-position) light
};

struct MisStrategy {
    enum class Kind { Connection, Merge } kind = Kind::Connection;
    int index = 0;  // s for a connection, m for a merge
};

// The balance-heuristic weight of `strategy` for the path of `vertexCount` vertices; 0 when the
// strategy is disabled or impossible for the path, or the densities are degenerate.
double misWeight(const MisVertex* path, size_t vertexCount, const MisStrategies& strategies,
                 MisStrategy strategy);

}  // namespace alphorn
