#include "common/scene/loop_subdivision.h"

#include "common/core/error.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace alphorn {

namespace {

using Positions = Eigen::Matrix<double, 3, Eigen::Dynamic>;
using Faces = Eigen::Matrix<uint32_t, 3, Eigen::Dynamic>;

// The mesh's connectivity through half-edges: half-edge h = 3f + k runs from corner k of face f
// to corner k + 1, so it leaves its face's vertices counter-clockwise (seen from the side the
// winding normal points to).
class Topology {
  public:
    Topology(const Faces& faces, size_t vertexCount, const std::string& source)
        : m_faces(faces), m_start(vertexCount + 1, 0) {
        const size_t halfEdges = 3 * size_t(faces.cols());
        for (size_t h = 0; h < halfEdges; ++h) ++m_start[tail(h) + 1];
        for (size_t v = 0; v < vertexCount; ++v) m_start[v + 1] += m_start[v];
        m_outgoing.resize(halfEdges);
        std::vector<uint32_t> filled(m_start.begin(), m_start.end() - 1);
        for (size_t h = 0; h < halfEdges; ++h) m_outgoing[filled[tail(h)]++] = uint32_t(h);
        // Each vertex's half-edges by the vertex they lead to: a twin is then found by binary
        // search, whatever the valence (a fan of a million faces around one vertex included).
        for (size_t v = 0; v < vertexCount; ++v)
            std::sort(m_outgoing.begin() + m_start[v], m_outgoing.begin() + m_start[v + 1],
                      [&](uint32_t a, uint32_t b) {
                          return std::make_pair(head(a), a) < std::make_pair(head(b), b);
                      });
        // Two faces running along an edge the same way: a third face on the edge, or
        // neighbours of opposite orientation. Either way the edge has no well-defined sides.
        for (size_t v = 0; v < vertexCount; ++v)
            for (uint32_t i = m_start[v]; i + 1 < m_start[v + 1]; ++i)
                if (head(m_outgoing[i]) == head(m_outgoing[i + 1]))
                    fail(
                        "%s: faces %d and %d both run from vertex %d to vertex %d: the mesh is not "
                        "a consistently oriented manifold (an edge with more than two faces, or "
                        "neighbouring faces of opposite orientation), which Loop subdivision needs",
                        source, m_outgoing[i] / 3, m_outgoing[i + 1] / 3, v, head(m_outgoing[i]));
        m_twin.assign(halfEdges, -1);
        for (size_t h = 0; h < halfEdges; ++h) {
            const uint32_t from = tail(h), to = head(h);
            const auto begin = m_outgoing.begin() + m_start[to];
            const auto end = m_outgoing.begin() + m_start[to + 1];
            const auto found = std::lower_bound(
                begin, end, from, [&](uint32_t g, uint32_t vertex) { return head(g) < vertex; });
            if (found != end && head(*found) == from) m_twin[h] = int32_t(*found);
        }
        m_edge.resize(halfEdges);
        for (size_t h = 0; h < halfEdges; ++h)
            m_edge[h] =
                m_twin[h] < 0 || size_t(m_twin[h]) > h ? m_edgeCount++ : m_edge[size_t(m_twin[h])];
    }

    uint32_t tail(size_t h) const { return m_faces(h % 3, h / 3); }
    uint32_t head(size_t h) const { return m_faces((h + 1) % 3, h / 3); }
    // The vertex of h's face that h does not touch.
    uint32_t opposite(size_t h) const { return m_faces((h + 2) % 3, h / 3); }
    static size_t previous(size_t h) { return 3 * (h / 3) + (h + 2) % 3; }
    int32_t twin(size_t h) const { return m_twin[h]; }
    uint32_t edge(size_t h) const { return m_edge[h]; }
    uint32_t edgeCount() const { return m_edgeCount; }
    // Whether h is the half-edge its edge is counted by (each edge has one).
    bool isEdgeRepresentative(size_t h) const { return m_twin[h] < 0 || size_t(m_twin[h]) > h; }

    // The neighbours of vertex v in counter-clockwise order; for a boundary vertex from the
    // neighbour along the boundary at the clockwise end to the one at the other end. Throws
    // Error when v's faces are not one fan around it (faces meeting only at v).
    bool ring(uint32_t v, std::vector<uint32_t>& neighbours, const std::string& source) const {
        neighbours.clear();
        const uint32_t first = m_start[v], last = m_start[v + 1];
        // A boundary vertex's fan starts at the half-edge leaving it along the boundary.
        uint32_t start = m_outgoing[first];
        bool boundary = false;
        for (uint32_t i = first; i < last; ++i)
            if (m_twin[m_outgoing[i]] < 0) {
                start = m_outgoing[i];
                boundary = true;
                break;
            }
        size_t h = start, faces = 0;
        while (true) {
            neighbours.push_back(head(h));
            ++faces;
            const size_t incoming = previous(h);
            if (m_twin[incoming] < 0) {
                if (!boundary) break;  // an open fan without a boundary start: refused below
                neighbours.push_back(tail(incoming));
                break;
            }
            h = size_t(m_twin[incoming]);
            if (h == start || faces > last - first) break;
        }
        if (faces != last - first || (!boundary && m_twin[previous(h)] < 0))
            fail(
                "%s: the faces around vertex %d do not form a single fan (faces meet only at "
                "this vertex): the mesh is not a manifold, which Loop subdivision needs",
                source, v);
        return boundary;
    }

  private:
    const Faces& m_faces;
    std::vector<uint32_t> m_start;     // per vertex, into m_outgoing
    std::vector<uint32_t> m_outgoing;  // the half-edges leaving each vertex
    std::vector<int32_t> m_twin;       // the half-edge running the other way, or -1
    std::vector<uint32_t> m_edge;
    uint32_t m_edgeCount = 0;
};

double beta(size_t valence) {
    return valence == 3 ? 3.0 / 16.0 : 3.0 / (8.0 * double(valence));
}

// The weight of each neighbour in an interior vertex's limit position.
double limitWeight(size_t valence) {
    return 1.0 / (double(valence) + 3.0 / (8.0 * beta(valence)));
}

Eigen::Vector3d ringSum(const Positions& p, const std::vector<uint32_t>& ring) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (uint32_t n : ring) sum += p.col(n);
    return sum;
}

// One round: the vertices moved (first, in their order) and one new vertex per edge (after
// them, in the edges' order); each face split into four.
void subdivideOnce(Positions& p, Faces& faces, const std::string& source) {
    const Topology topology(faces, size_t(p.cols()), source);
    const Eigen::Index vertexCount = p.cols();
    Positions next(3, vertexCount + Eigen::Index(topology.edgeCount()));
    std::vector<uint32_t> ring;
    for (Eigen::Index v = 0; v < vertexCount; ++v) {
        const bool boundary = topology.ring(uint32_t(v), ring, source);
        if (boundary) {
            next.col(v) = 0.75 * p.col(v) + 0.125 * (p.col(ring.front()) + p.col(ring.back()));
        } else {
            const double b = beta(ring.size());
            next.col(v) = (1.0 - double(ring.size()) * b) * p.col(v) + b * ringSum(p, ring);
        }
    }
    const size_t halfEdges = 3 * size_t(faces.cols());
    for (size_t h = 0; h < halfEdges; ++h) {
        if (!topology.isEdgeRepresentative(h)) continue;
        const auto a = p.col(topology.tail(h)), b = p.col(topology.head(h));
        const Eigen::Index column = vertexCount + Eigen::Index(topology.edge(h));
        if (topology.twin(h) < 0)
            next.col(column) = 0.5 * (a + b);
        else
            next.col(column) =
                0.375 * (a + b) + 0.125 * (p.col(topology.opposite(h)) +
                                           p.col(topology.opposite(size_t(topology.twin(h)))));
    }
    Faces split(3, 4 * faces.cols());
    for (Eigen::Index f = 0; f < faces.cols(); ++f) {
        const uint32_t v0 = faces(0, f), v1 = faces(1, f), v2 = faces(2, f);
        // The new vertices on the edges v0-v1, v1-v2 and v2-v0.
        const uint32_t m0 = uint32_t(vertexCount) + topology.edge(3 * size_t(f));
        const uint32_t m1 = uint32_t(vertexCount) + topology.edge(3 * size_t(f) + 1);
        const uint32_t m2 = uint32_t(vertexCount) + topology.edge(3 * size_t(f) + 2);
        split.col(4 * f) << v0, m0, m2;
        split.col(4 * f + 1) << m0, v1, m1;
        split.col(4 * f + 2) << m2, m1, v2;
        split.col(4 * f + 3) << m0, m1, m2;
    }
    p = std::move(next);
    faces = std::move(split);
}

}  // namespace

TriangleGeometry loopSubdivide(const Eigen::Matrix<float, 3, Eigen::Dynamic>& positions,
                               const Eigen::Matrix<uint32_t, 3, Eigen::Dynamic>& faces, int levels,
                               const std::string& source) {
    if (levels < 0) fail("%s: the subdivision levels must be 0 or more, got %d", source, levels);
    if (faces.cols() == 0) fail("%s: the mesh to subdivide has no triangles", source);
    uint64_t triangles = uint64_t(faces.cols());
    for (int level = 0; level < levels; ++level) {
        triangles *= 4;
        if (triangles > kMaxLoopSubdivisionTriangles)
            fail(
                "%s: %d levels of subdivision would make %d triangles or more from %d, beyond the "
                "%d allowed (each level makes 4 of every triangle)",
                source, levels, triangles, faces.cols(), kMaxLoopSubdivisionTriangles);
    }
    if (triangles > kMaxLoopSubdivisionTriangles)
        fail("%s: the mesh has %d triangles, more than the %d subdivision allows", source,
             triangles, kMaxLoopSubdivisionTriangles);

    // The vertices the faces use, renumbered in their order: an unused vertex has no
    // neighbours to take weights from and is no part of the surface.
    const Eigen::Index inputCount = positions.cols();
    std::vector<int64_t> renumbered(size_t(inputCount), -1);
    for (Eigen::Index f = 0; f < faces.cols(); ++f) {
        for (int k = 0; k < 3; ++k) {
            const uint32_t v = faces(k, f);
            if (v >= uint64_t(inputCount))
                fail("%s: triangle %d uses vertex %d, but the mesh has %d vertices", source, f, v,
                     inputCount);
            renumbered[v] = 0;
        }
        if (faces(0, f) == faces(1, f) || faces(1, f) == faces(2, f) || faces(2, f) == faces(0, f))
            fail("%s: triangle %d uses vertex %d twice", source, f,
                 faces(1, f) == faces(2, f) ? faces(1, f) : faces(0, f));
    }
    uint32_t used = 0;
    for (int64_t& index : renumbered)
        if (index == 0)
            index = used++;
        else
            index = -1;
    Faces current(3, faces.cols());
    for (Eigen::Index f = 0; f < faces.cols(); ++f)
        for (int k = 0; k < 3; ++k) current(k, f) = uint32_t(renumbered[faces(k, f)]);
    Positions p(3, used);
    for (Eigen::Index v = 0; v < inputCount; ++v) {
        if (renumbered[size_t(v)] < 0) continue;
        if (!positions.col(v).allFinite())
            fail("%s: vertex %d has a position that is not finite", source, v);
        p.col(renumbered[size_t(v)]) = positions.col(v).cast<double>();
    }

    for (int level = 0; level < levels; ++level) subdivideOnce(p, current, source);

    // The limit positions, then the limit tangents from them.
    const Topology topology(current, size_t(p.cols()), source);
    const Eigen::Index count = p.cols();
    std::vector<std::vector<uint32_t>> rings(static_cast<size_t>(count));
    std::vector<bool> boundary(static_cast<size_t>(count));
    Positions limit(3, count);
    for (Eigen::Index v = 0; v < count; ++v) {
        std::vector<uint32_t>& ring = rings[size_t(v)];
        boundary[size_t(v)] = topology.ring(uint32_t(v), ring, source);
        if (boundary[size_t(v)]) {
            limit.col(v) = 0.6 * p.col(v) + 0.2 * (p.col(ring.front()) + p.col(ring.back()));
        } else {
            const double g = limitWeight(ring.size());
            limit.col(v) = (1.0 - double(ring.size()) * g) * p.col(v) + g * ringSum(p, ring);
        }
    }

    TriangleGeometry geometry;
    geometry.positions = limit.cast<float>();
    geometry.normals.resize(3, count);
    for (Eigen::Index v = 0; v < count; ++v) {
        const std::vector<uint32_t>& ring = rings[size_t(v)];
        const size_t n = ring.size();
        auto q = [&](size_t i) -> Eigen::Vector3d { return limit.col(ring[i]); };
        const Eigen::Vector3d center = limit.col(v);
        Eigen::Vector3d s = Eigen::Vector3d::Zero(), t = Eigen::Vector3d::Zero(), normal;
        if (!boundary[size_t(v)]) {
            // The limit surface's tangents are the first Fourier components of the ring. This
            // ring runs counter-clockwise, pbrt's the other way: t x s is pbrt's s x t.
            for (size_t j = 0; j < n; ++j) {
                const double angle = 2.0 * M_PI * double(j) / double(n);
                s += std::cos(angle) * q(j);
                t += std::sin(angle) * q(j);
            }
            normal = t.cross(s);
        } else {
            // Along the boundary, and across it into the surface.
            s = q(n - 1) - q(0);
            if (n == 2) {
                t = q(0) + q(1) - 2.0 * center;
            } else if (n == 3) {
                t = q(1) - center;
            } else if (n == 4) {
                t = -q(0) + 2.0 * q(1) + 2.0 * q(2) - q(3) - 2.0 * center;
            } else {
                const double theta = M_PI / double(n - 1);
                t = std::sin(theta) * (q(0) + q(n - 1));
                for (size_t k = 1; k + 1 < n; ++k)
                    t += (2.0 * std::cos(theta) - 2.0) * std::sin(double(k) * theta) * q(k);
                t = -t;
            }
            normal = s.cross(t);
        }
        const double length = normal.norm();
        geometry.normals.col(v) = length > 0.0 && std::isfinite(length)
                                      ? Eigen::Vector3f((normal / length).cast<float>())
                                      : Eigen::Vector3f::Zero();
    }
    geometry.faces = std::move(current);
    return geometry;
}

}  // namespace alphorn
