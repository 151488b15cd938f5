// <mesh type="obj">: a Wavefront OBJ file (Nori's WavefrontOBJ). Polygons are triangulated;
// a vertex is unique per (position, uv, normal) triple; missing normals give flat shading.
#include "common/core/decimal_number.h"
#include "common/core/transform.h"
#include "common/scene/mesh.h"
#include "common/scene/scene_load.h"

#include <absl/container/flat_hash_set.h>
#include <absl/strings/str_format.h>

#include <tiny_obj_loader.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <tuple>

namespace alphorn {

namespace {

// "v", "vt", "vn": how many numbers a line may hold. tinyobjloader reads x y z of a position
// and either w (ignored) or r g b (vertex colours); u [v [w]] of a texture coordinate (the OBJ
// format's optional v and w default to 0); x y z of a normal.
bool isAcceptedCount(std::string_view keyword, size_t count) {
    if (keyword == "v") return count == 3 || count == 4 || count == 6;
    if (keyword == "vt") return count >= 1 && count <= 3;
    return count == 3;
}
const char* acceptedCounts(std::string_view keyword) {
    if (keyword == "v") return "3 (x y z), 4 (x y z w) or 6 (x y z r g b)";
    if (keyword == "vt") return "1 to 3 (u [v [w]])";
    return "3 (x y z)";
}

// The token of `line` that starts at or after `position` (tokens are separated by spaces and
// tabs, as tinyobjloader separates them); empty at the end of the line. `position` moves past
// it. (Plain loops: string_view::find_first_of calls memchr once per character.)
std::string_view nextToken(std::string_view line, size_t& position) {
    auto isSpace = [](char c) { return c == ' ' || c == '\t'; };
    size_t start = position;
    while (start < line.size() && isSpace(line[start])) ++start;
    position = start;
    while (position < line.size() && !isSpace(line[position])) ++position;
    return line.substr(start, position - start);
}

// One index of a face vertex: a nonzero decimal integer within int's range (a negative one
// counts back from the last vertex read). tinyobjloader reads indices with atoi, which wraps
// beyond that range and reads "1.5" as 1.
bool parseObjIndex(std::string_view s, int& index) {
    const bool negative = !s.empty() && s[0] == '-';
    size_t i = !s.empty() && (s[0] == '+' || s[0] == '-') ? 1 : 0;
    if (i == s.size()) return false;
    int64_t value = 0;
    for (; i < s.size(); ++i) {
        if (s[i] < '0' || s[i] > '9') return false;
        value = value * 10 + (s[i] - '0');
        if (value > std::numeric_limits<int>::max()) return false;
    }
    index = static_cast<int>(negative ? -value : value);
    return value != 0;
}

// A face vertex as written: its position, texture coordinate and normal indices (0: none).
struct FaceVertex {
    int position = 0, uv = 0, normal = 0;
};

// A face vertex: i, i/j, i//k or i/j/k (position, texture coordinate and normal indices).
bool parseFaceVertex(std::string_view token, FaceVertex& vertex) {
    vertex = FaceVertex();
    const size_t first = token.find('/');
    if (first == std::string_view::npos) return parseObjIndex(token, vertex.position);
    if (!parseObjIndex(token.substr(0, first), vertex.position)) return false;
    const std::string_view rest = token.substr(first + 1);
    const size_t second = rest.find('/');
    if (second == std::string_view::npos) return parseObjIndex(rest, vertex.uv);
    const std::string_view uv = rest.substr(0, second);
    return (uv.empty() || parseObjIndex(uv, vertex.uv)) &&
           parseObjIndex(rest.substr(second + 1), vertex.normal);
}

// What the pass over an OBJ file counts when asked to (countObjFile): the lines read so far,
// which relative (negative) indices count back from, and the mesh the faces make.
struct ObjCounter {
    int positions = 0, uvs = 0, normals = 0;  // "v", "vt" and "vn" lines so far
    // The distinct (position, uv, normal) triples, resolved as tinyobjloader resolves them (-1:
    // none): the loader makes one vertex of each.
    absl::flat_hash_set<std::tuple<int, int, int>> vertices;
    ObjCounts counts;

    static int resolved(int index, int count) { return index > 0 ? index - 1 : count + index; }
    void addFaceVertex(const FaceVertex& vertex) {
        vertices.emplace(resolved(vertex.position, positions),
                         vertex.uv == 0 ? -1 : resolved(vertex.uv, uvs),
                         vertex.normal == 0 ? -1 : resolved(vertex.normal, normals));
        counts.uvs &= vertex.uv != 0;
        counts.normals &= vertex.normal != 0;
    }
};

// Whether the decimal number `s` is finite as a float, as tinyobjloader reads it (1e39 is
// infinite). Without an exponent, 38 digits before the point always fit: strtof, the costly
// part, is only needed for the rest.
bool fitsFloat(std::string_view s) {
    size_t integerDigits = 0;
    bool point = false, exponent = false;
    for (const char c : s) {
        exponent |= c == 'e' || c == 'E';
        point |= c == '.';
        integerDigits += !point && c >= '0' && c <= '9';
    }
    return (!exponent && integerDigits <= 38) ||
           std::isfinite(std::strtof(std::string(s).c_str(), nullptr));
}

// The problem with one line of an OBJ file that tinyobjloader would misread without a word, or
// would take too long over, or "" when there is none. Only the lines Alphorn uses are checked:
// v, vt, vn and f. With a counter, the line is counted too. `faceVertices` is set to the
// vertices of a face line (0 for other lines).
std::string lineProblem(std::string_view line, ObjCounter* counter, size_t& faceVertices) {
    faceVertices = 0;
    // tinyobjloader's lines end at a NUL byte: whatever follows it would be dropped.
    if (line.find('\0') != std::string_view::npos) return "the line contains a NUL byte";
    size_t position = 0;
    const std::string_view keyword = nextToken(line, position);
    const bool numbers = keyword == "v" || keyword == "vt" || keyword == "vn";
    if (!numbers && keyword != "f") return "";
    auto shown = [&] { return std::string(line.substr(line.find_first_not_of(" \t"), 60)); };
    size_t count = 0;
    FaceVertex vertex;
    // A comment may end the numbers (tinyobjloader stops at what is no number); in a face it
    // is an error to tinyobjloader, reported below as no face vertex.
    for (std::string_view token = nextToken(line, position);
         !token.empty() && !(numbers && token[0] == '#');
         token = nextToken(line, position), ++count) {
        if (!numbers && !parseFaceVertex(token, vertex))
            return absl::StrFormat(
                "\"%s\": \"%s\" is not a face vertex (i, i/j, i//k or i/j/k, with nonzero integer "
                "indices within +-2147483647)",
                shown(), token.substr(0, 40));
        if (numbers && !(isDecimalNumber(token) && fitsFloat(token)))
            return absl::StrFormat("\"%s\": \"%s\" is not a finite decimal number", shown(),
                                   token.substr(0, 40));
        if (!numbers && counter && count < kMaxObjFaceVertices) counter->addFaceVertex(vertex);
    }
    if (!numbers && count < 3)
        return absl::StrFormat("\"%s\": a face needs at least 3 vertices", shown());
    // tinyobjloader triangulates a polygon by ear clipping, in time quadratic in its vertices:
    // 90000 vertices took 14 s, 4096 take about 0.05 s.
    if (!numbers && count > kMaxObjFaceVertices)
        return absl::StrFormat(
            "a face with %d vertices; at most %d (triangulating a polygon takes time quadratic in "
            "its vertices)",
            count, kMaxObjFaceVertices);
    if (!numbers) faceVertices = count;
    if (numbers && !isAcceptedCount(keyword, count))
        return absl::StrFormat("\"%s\" has %d numbers; \"%s\" takes %s", shown(), count, keyword,
                               acceptedCounts(keyword));
    if (counter) {
        if (keyword == "v") ++counter->positions;
        if (keyword == "vt") ++counter->uvs;
        if (keyword == "vn") ++counter->normals;
        if (keyword == "f") counter->counts.triangles += count - 2;
    }
    return "";
}

// One pass over the lines as tinyobjloader splits them (at \n, \r or \r\n): each is checked
// (and counted, with a counter), and so is the file's triangulation work; with `prepare`, the
// "vw" lines are emptied. Returns the "f" lines.
size_t scanObjText(std::string& text, const std::string& name, bool prepare, ObjCounter* counter) {
    size_t read = 0, write = 0, lineNumber = 1, faceCount = 0, faceVertices = 0;
    uint64_t triangulationWork = 0;
    while (read < text.size()) {
        size_t lineEnd = read;
        while (lineEnd < text.size() && text[lineEnd] != '\n' && text[lineEnd] != '\r') ++lineEnd;
        size_t breakEnd = lineEnd;
        if (breakEnd < text.size())
            breakEnd +=
                text[breakEnd] == '\r' && breakEnd + 1 < text.size() && text[breakEnd + 1] == '\n'
                    ? 2
                    : 1;
        const std::string_view line(text.data() + read, lineEnd - read);
        const std::string problem = lineProblem(line, counter, faceVertices);
        if (!problem.empty()) fail("%s:%d: %s", name, lineNumber, problem);
        // Each face within kMaxObjFaceVertices is quick to triangulate, but a file of thousands
        // of them is not.
        if (faceVertices > 4) {
            triangulationWork += uint64_t(faceVertices) * faceVertices;
            if (triangulationWork > kMaxObjTriangulationWork)
                fail(
                    "%s:%d: a face with %d vertices takes the file beyond the triangulation work "
                    "allowed: the squares of the vertex counts of its faces of more than 4 "
                    "vertices "
                    "add up to %u, more than %u (%d faces of %d vertices; triangulating a polygon "
                    "takes time quadratic in its vertices)",
                    name, lineNumber, faceVertices, triangulationWork, kMaxObjTriangulationWork,
                    kMaxObjTriangulationWork / (kMaxObjFaceVertices * kMaxObjFaceVertices),
                    kMaxObjFaceVertices);
        }
        size_t afterKeyword = 0;
        const std::string_view keyword = nextToken(line, afterKeyword);
        faceCount += keyword == "f";
        lineNumber += breakEnd > lineEnd;
        if (prepare) {
            // The line's text goes, its break stays.
            const size_t kept = keyword == "vw" && afterKeyword < line.size() ? lineEnd : read;
            if (write != kept)
                std::memmove(text.data() + write, text.data() + kept, breakEnd - kept);
            write += breakEnd - kept;
        }
        read = breakEnd;
    }
    if (prepare) text.resize(write);
    if (counter) counter->counts.triangulationWork = triangulationWork;
    return faceCount;
}

std::ifstream openObjFile(const std::string& path) {
    std::ifstream file(path, std::ios::binary);
    if (!file) fail("cannot open OBJ file \"%s\": %s", path, std::strerror(errno));
    return file;
}

// Read in one call into a string of the file's size: copying the file through a growing
// stringstream took longer than scanning the text (a copy per doubling, each faulting in fresh
// pages). A file that grew meanwhile is read to its end.
std::string readObjFile(const std::string& path) {
    std::ifstream file(path, std::ios::binary | std::ios::ate);
    if (!file) fail("cannot open OBJ file \"%s\": %s", path, std::strerror(errno));
    const std::streamoff size = file.tellg();
    file.seekg(0);
    std::string text(size > 0 ? static_cast<size_t>(size) : 0, '\0');
    file.read(text.data(), static_cast<std::streamsize>(text.size()));
    text.resize(static_cast<size_t>(file.gcount()));
    if (file) {
        std::ostringstream rest;
        rest << file.rdbuf();
        text += std::move(rest).str();
    }
    return text;
}

}  // namespace

// tinyobjloader's "vw" extension (skin weights) converts joint ids from float to int unchecked,
// which is undefined behaviour for ids beyond the int range; Alphorn has no use for skin weights.
// Line breaks stay, so line numbers still match the file.
ObjText preparedForTinyObj(std::string text, const std::string& name) {
    const size_t faceCount = scanObjText(text, name, /*prepare=*/true, nullptr);
    return {std::move(text), faceCount};
}

CountedObj countedAndPreparedObjText(std::string text, const std::string& name) {
    ObjCounter counter;
    const size_t faceCount = scanObjText(text, name, /*prepare=*/true, &counter);
    counter.counts.faces = faceCount;
    counter.counts.vertices = counter.vertices.size();
    if (counter.counts.faces == 0) counter.counts.normals = counter.counts.uvs = false;
    return {counter.counts, {std::move(text), faceCount}};
}

ObjCounts countObjText(std::string text, const std::string& name) {
    return countedAndPreparedObjText(std::move(text), name).counts;
}

CountedObj countedAndPreparedObjFile(const std::string& path) {
    return countedAndPreparedObjText(readObjFile(path), path);
}

ObjCounts countObjFile(const std::string& path) {
    return countedAndPreparedObjFile(path).counts;
}

// Embree refuses (asserts on) rays whose origin has a coordinate beyond about 1.8e18, and rays
// leave from surface points; this bound keeps every point on a mesh far inside that range.
constexpr float kMaxVertexCoordinate = 1e15f;

class WavefrontOBJ : public Mesh {
  public:
    explicit WavefrontOBJ(const PropertyList& props) {
        std::string filename = props.getString("filename");
        std::string path = props.resolvePath(filename);
        Transform toWorld = props.getTransform("toWorld", Transform());
        m_name = filename;
        // The file's mesh is built once for every <mesh> of the scene that names it, from the
        // text the parser's count read and checked when it kept it.
        auto build = [&](std::optional<ObjText> counted) {
            return readGeometry(props, path, std::move(counted));
        };
        SceneLoadContext* context = props.loadContext();
        place(props, path, context ? *context->objGeometry(path, build) : build(std::nullopt),
              toWorld);
    }

  private:
    // The mesh of the file at `path`, from `counted` (its text as the count prepared it) or,
    // without it, from the file read and prepared here.
    static ObjGeometry readGeometry(const PropertyList& props, const std::string& path,
                                    std::optional<ObjText> counted) {
        ObjText prepared;
        if (counted) {
            prepared = std::move(*counted);
        } else {
            std::string text;
            try {
                text = readObjFile(path);
            } catch (const Error& e) {
                props.fail("%s", e.what());
            }
            try {
                prepared = preparedForTinyObj(std::move(text), path);
            } catch (const Error& e) {
                props.fail("OBJ file %s", e.what());
            }
        }
        std::istringstream stream(std::move(prepared.text));

        tinyobj::attrib_t attrib;
        std::vector<tinyobj::shape_t> shapes;
        std::vector<tinyobj::material_t> materials;
        std::string warn, err;
        // Materials are ignored (BSDFs come from the scene file), so no material reader.
        bool ok = tinyobj::LoadObj(&attrib, &shapes, &materials, &warn, &err, &stream, nullptr,
                                   /*triangulate=*/true);
        if (!ok || !err.empty()) props.fail("cannot parse OBJ file \"%s\": %s", path, err);

        std::map<std::tuple<int, int, int>, uint32_t> vertexIds;
        std::vector<std::array<int, 3>> keys;
        std::vector<uint32_t> faceIndices;
        const int positionCount = static_cast<int>(attrib.vertices.size() / 3);
        const int normalCount = static_cast<int>(attrib.normals.size() / 3);
        const int uvCount = static_cast<int>(attrib.texcoords.size() / 2);
        bool allNormals = true, allUvs = true;
        for (const auto& shape : shapes) {
            for (const auto& index : shape.mesh.indices) {
                if (index.vertex_index < 0 || index.vertex_index >= positionCount ||
                    index.normal_index >= normalCount || index.texcoord_index >= uvCount)
                    props.fail("OBJ file \"%s\" has a face with an out-of-range index", path);
                auto key =
                    std::make_tuple(index.vertex_index, index.normal_index, index.texcoord_index);
                auto [it, inserted] =
                    vertexIds.emplace(key, static_cast<uint32_t>(vertexIds.size()));
                if (inserted) {
                    keys.push_back({index.vertex_index, index.normal_index, index.texcoord_index});
                    allNormals &= index.normal_index >= 0;
                    allUvs &= index.texcoord_index >= 0;
                }
                faceIndices.push_back(it->second);
            }
        }
        // tinyobjloader drops the polygons it cannot triangulate: that is not an empty file.
        if (faceIndices.empty() && prepared.faceCount > 0)
            props.fail(
                "OBJ file \"%s\" has %d face%s, but triangulating %s gave no triangle (%s "
                "vertices are collinear or coincide)",
                path, prepared.faceCount, prepared.faceCount == 1 ? "" : "s",
                prepared.faceCount == 1 ? "it" : "them", prepared.faceCount == 1 ? "its" : "their");
        if (faceIndices.empty()) props.fail("OBJ file \"%s\" contains no faces", path);

        const size_t n = keys.size();
        ObjGeometry geometry;
        geometry.positions.resize(3, n);
        geometry.normals.resize(3, allNormals ? n : 0);
        geometry.uvs.resize(2, allUvs ? n : 0);
        for (size_t i = 0; i < n; ++i) {
            const auto& [p, nIdx, t] = keys[i];
            geometry.positions.col(i) = Point3f(attrib.vertices[3 * p], attrib.vertices[3 * p + 1],
                                                attrib.vertices[3 * p + 2]);
            if (allNormals)
                geometry.normals.col(i) =
                    Normal3f(attrib.normals[3 * nIdx], attrib.normals[3 * nIdx + 1],
                             attrib.normals[3 * nIdx + 2]);
            if (allUvs)
                geometry.uvs.col(i) = Point2f(attrib.texcoords[2 * t], attrib.texcoords[2 * t + 1]);
        }
        geometry.faces.resize(3, faceIndices.size() / 3);
        std::copy(faceIndices.begin(), faceIndices.end(), geometry.faces.data());
        return geometry;
    }

    // This mesh: the file's mesh moved into the scene by toWorld.
    void place(const PropertyList& props, const std::string& path, const ObjGeometry& geometry,
               const Transform& toWorld) {
        const bool hasNormals = geometry.normals.cols() > 0;
        const size_t n = geometry.positions.cols();
        Eigen::Matrix<float, 3, Eigen::Dynamic> positions(3, n);
        Eigen::Matrix<float, 3, Eigen::Dynamic> normals(3, geometry.normals.cols());
        for (size_t i = 0; i < n; ++i) {
            positions.col(i) = toWorld.applyPoint(Point3f(geometry.positions.col(i)));
            if (!positions.col(i).allFinite())
                props.fail("OBJ file \"%s\" has a non-finite vertex position", path);
            if (positions.col(i).cwiseAbs().maxCoeff() > kMaxVertexCoordinate)
                props.fail(
                    "OBJ file \"%s\" has a vertex at (%g, %g, %g), farther out than %g (after "
                    "toWorld), where rays cannot be traced",
                    path, positions(0, i), positions(1, i), positions(2, i), kMaxVertexCoordinate);
            if (hasNormals) {
                Normal3f world = toWorld.applyNormal(Normal3f(geometry.normals.col(i)));
                float length = world.norm();
                // Under a tiny or huge scale the transformed normal's squared length leaves the
                // float range (1e20^2 under a scale of 1e-20) though the normal is fine: scaled
                // by its largest component first, it normalises. Other normals keep their bytes.
                if (!std::isnormal(length) && world.allFinite() && !world.isZero()) {
                    world /= world.cwiseAbs().maxCoeff();
                    length = world.norm();
                }
                // A zero normal in the file falls back to the geometric normal at shading time.
                normals.col(i) = length > 0.0f ? Normal3f(world / length) : Normal3f::Zero();
            }
        }
        setGeometry(std::move(positions), std::move(normals), geometry.uvs, geometry.faces);
    }
};

ALPHORN_REGISTER(Mesh, "obj", WavefrontOBJ);

// The file a <mesh type="obj"> reads, for listing a scene's files: opened, not read.
void listObjFile(const PropertyList& props) {
    const std::string path = props.resolvePath(props.getString("filename"));
    try {
        openObjFile(path);
    } catch (const Error& e) {
        props.fail("%s", e.what());
    }
}
ALPHORN_REGISTER_FILES(Mesh, "obj", listObjFile);

}  // namespace alphorn
