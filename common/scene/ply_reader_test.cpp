#include "common/scene/ply_reader.h"

#include "common/core/error.h"
#include "common/scene/loop_subdivision.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <absl/strings/str_format.h>

#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace alphorn {
namespace {

namespace fs = std::filesystem;

// A directory of this test's own, removed at its end.
class PlyFiles : public ::testing::Test {
  protected:
    void SetUp() override {
        m_directory =
            fs::temp_directory_path() /
            absl::StrFormat("alphorn_ply_test_%d_%s", ::getpid(),
                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::create_directories(m_directory);
    }
    void TearDown() override { fs::remove_all(m_directory); }

    std::string write(const std::string& name, const std::string& bytes) {
        const std::string path = (m_directory / name).string();
        std::ofstream(path, std::ios::binary) << bytes;
        return path;
    }

    fs::path m_directory;
};

enum class Format { Ascii, Little, Big };

const char* formatName(Format format) {
    return format == Format::Ascii    ? "ascii"
           : format == Format::Little ? "binary_little_endian"
                                      : "binary_big_endian";
}

// Writes values of PLY types in one format.
class PlyWriter {
  public:
    explicit PlyWriter(Format format) : m_format(format) {}

    template <typename T>
    void put(T value) {
        if (m_format == Format::Ascii) {
            if constexpr (std::is_floating_point_v<T>)
                m_data += absl::StrFormat("%.17g ", value);
            else
                m_data += absl::StrFormat("%d ", int64_t(value));
            return;
        }
        unsigned char raw[sizeof(T)];
        std::memcpy(raw, &value, sizeof(T));
        // This machine is little-endian (x86-64 and arm64 as Alphorn builds them).
        for (size_t i = 0; i < sizeof(T); ++i)
            m_data.push_back(char(raw[m_format == Format::Little ? i : sizeof(T) - 1 - i]));
    }
    void endRow() {
        if (m_format == Format::Ascii) m_data += "\n";
    }
    const std::string& data() const { return m_data; }

  private:
    Format m_format;
    std::string m_data;
};

// Five vertices and a triangle, a quad and a pentagon over them, with properties Alphorn skips
// around the ones it reads (a vertex colour, a list on the vertices, per-face indices, a list of
// floats on the faces, and a whole element of lists before the faces).
std::string sampleMesh(Format format, bool doublePositions = false) {
    const float p[5][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0.5f}, {0.25f, 2, -1}};
    const float uv[5][2] = {{0, 0}, {1, 0}, {0, 1}, {1, 1}, {0.5f, 0.75f}};
    std::string header =
        absl::StrFormat("ply\nformat %s 1.0\ncomment made by a test\n", formatName(format));
    const char* positionType = doublePositions ? "double" : "float";
    header += absl::StrFormat(
        "element vertex 5\nproperty %s x\nproperty uchar red\nproperty %s y\nproperty %s z\n"
        "property list uchar int neighbours\nproperty float nx\nproperty float ny\n"
        "property float nz\nproperty float u\nproperty float v\n",
        positionType, positionType, positionType);
    header += "element edge 2\nproperty list ushort double weights\nproperty short id\n";
    header +=
        "element face 3\nproperty list uchar int vertex_indices\nproperty int face_indices\n"
        "property list int float junk\nend_header\n";
    PlyWriter w(format);
    for (int i = 0; i < 5; ++i) {
        if (doublePositions)
            w.put(double(p[i][0]));
        else
            w.put(p[i][0]);
        w.put(uint8_t(200 + i));
        for (int k = 1; k < 3; ++k) {
            if (doublePositions)
                w.put(double(p[i][k]));
            else
                w.put(p[i][k]);
        }
        w.put(uint8_t(i % 3));
        for (int k = 0; k < i % 3; ++k) w.put(int32_t(-7 * k));
        w.put(0.0f), w.put(0.0f), w.put(1.0f);
        w.put(uv[i][0]), w.put(uv[i][1]);
        w.endRow();
    }
    for (int e = 0; e < 2; ++e) {
        w.put(uint16_t(e + 1));
        for (int k = 0; k <= e; ++k) w.put(1.5 * k);
        w.put(int16_t(-e));
        w.endRow();
    }
    const std::vector<std::vector<int32_t>> faces = {{0, 1, 2}, {1, 3, 4, 2}, {0, 1, 3, 4, 2}};
    for (size_t f = 0; f < faces.size(); ++f) {
        w.put(uint8_t(faces[f].size()));
        for (int32_t index : faces[f]) w.put(index);
        w.put(int32_t(10 + f));
        w.put(int32_t(f));
        for (size_t k = 0; k < f; ++k) w.put(0.5f);
        w.endRow();
    }
    return header + w.data();
}

std::string gzipped(const std::string& bytes) {
    z_stream stream{};
    EXPECT_EQ(
        deflateInit2(&stream, Z_BEST_SPEED, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY),
        Z_OK);
    std::string out(deflateBound(&stream, bytes.size()) + 64, '\0');
    stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
    stream.avail_in = uInt(bytes.size());
    stream.next_out = reinterpret_cast<Bytef*>(out.data());
    stream.avail_out = uInt(out.size());
    EXPECT_EQ(deflate(&stream, Z_FINISH), Z_STREAM_END);
    out.resize(stream.total_out);
    deflateEnd(&stream);
    return out;
}

void expectSampleGeometry(const TriangleGeometry& g) {
    ASSERT_EQ(g.positions.cols(), 5);
    ASSERT_EQ(g.normals.cols(), 5);
    ASSERT_EQ(g.uvs.cols(), 5);
    EXPECT_EQ(g.positions.col(3), Eigen::Vector3f(1, 1, 0.5f));
    EXPECT_EQ(g.positions.col(4), Eigen::Vector3f(0.25f, 2, -1));
    EXPECT_EQ(g.normals.col(4), Eigen::Vector3f(0, 0, 1));
    EXPECT_EQ(g.uvs.col(4), Eigen::Vector2f(0.5f, 0.75f));
    // The triangle; the quad 1 3 4 2 as (1 3 4) and (1 4 2); the pentagon 0 1 3 4 2 as a fan.
    Eigen::Matrix<uint32_t, 3, Eigen::Dynamic> expected(3, 6);
    expected << 0, 1, 1, 0, 0, 0,  //
        1, 3, 4, 1, 3, 4,          //
        2, 4, 2, 3, 4, 2;
    EXPECT_EQ(g.faces, expected);
}

bool same(const TriangleGeometry& a, const TriangleGeometry& b) {
    return a.positions == b.positions && a.normals == b.normals && a.uvs == b.uvs &&
           a.faces == b.faces;
}

TEST_F(PlyFiles, EveryFormatGivesTheSameGeometry) {
    const TriangleGeometry ascii = readPlyFile(write("a.ply", sampleMesh(Format::Ascii)), "a.ply");
    expectSampleGeometry(ascii);
    for (Format format : {Format::Ascii, Format::Little, Format::Big})
        for (bool doubles : {false, true})
            for (bool gz : {false, true}) {
                SCOPED_TRACE(absl::StrFormat("%s, %s positions%s", formatName(format),
                                             doubles ? "double" : "float", gz ? ", gzip" : ""));
                std::string bytes = sampleMesh(format, doubles);
                if (gz) bytes = gzipped(bytes);
                const TriangleGeometry g =
                    readPlyFile(write(gz ? "m.ply.gz" : "m.ply", bytes), "m.ply");
                EXPECT_TRUE(same(g, ascii));
            }
}

// Each error names the file as the caller asked, and says what is wrong.
void expectRefused(const std::string& bytes, const std::string& problem) {
    try {
        readPlyBytes(bytes, "meshes/bad.ply");
        ADD_FAILURE() << "accepted; expected \"" << problem << "\"";
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_EQ(message.rfind("meshes/bad.ply", 0), 0u) << message;
        EXPECT_NE(message.find(problem), std::string::npos) << message;
    }
}

TEST_F(PlyFiles, RefusesTruncatedFiles) {
    for (Format format : {Format::Little, Format::Big}) {
        const std::string bytes = sampleMesh(format);
        // Cut within the faces: the header's counts still fit the smallest rows, the reading
        // then runs out. Cut in the vertices: the counts no longer fit at all.
        expectRefused(bytes.substr(0, bytes.size() - 10), "truncated");
        expectRefused(bytes.substr(0, bytes.size() - 150), "truncated");
        expectRefused(gzipped(bytes).substr(0, 40), "truncated");
    }
    const std::string ascii = sampleMesh(Format::Ascii);
    expectRefused(ascii.substr(0, ascii.size() - 12), "truncated");
}

TEST_F(PlyFiles, RefusesBadHeaders) {
    expectRefused("plx\nformat ascii 1.0\nend_header\n", "not a PLY file");
    expectRefused("ply\nformat ebcdic 1.0\nend_header\n", "unknown format");
    expectRefused("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n",
                  "no \"end_header\"");
    expectRefused("ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n",
                  "unknown type");
    expectRefused("ply\nformat ascii 1.0\nelement vertex -1\nend_header\n", "element count");
    expectRefused("ply\nformat ascii 1.0\nproperty float x\nend_header\n",
                  "property before any element");
    expectRefused(
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
        "element face 0\nproperty list uchar int vertex_indices\nend_header\n0 0\n",
        "lacks one of the properties x, y and z");
    expectRefused(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nend_header\n0 0 0 1 0 0 0 1 0\n",
        "no \"face\" element");
    // A header line names its line number.
    expectRefused("ply\nformat ascii 1.0\ncomment fine\nelemnt vertex 3\nend_header\n",
                  "meshes/bad.ply:4: an unknown keyword");
}

TEST_F(PlyFiles, RefusesCountsBeyondTheFileBeforeAllocating) {
    const std::string header =
        "ply\nformat binary_little_endian 1.0\nelement vertex 2147483648\nproperty float x\n"
        "property float y\nproperty float z\nelement face 1\n"
        "property list uchar int vertex_indices\nend_header\n";
    const std::string file = header + std::string(100, '\0');
    const auto start = std::chrono::steady_clock::now();
    expectRefused(file, "declares 2147483648 vertex, 1 face, which take at least 25769803777");
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(100));
    // A count whose bytes overflow 64 bits, an element of no properties but a huge count, and
    // a list that claims more items than the file holds.
    expectRefused(
        "ply\nformat binary_little_endian 1.0\nelement vertex 9223372036854775807\n"
        "property double x\nend_header\n",
        "truncated or its counts are wrong");
    expectRefused(
        "ply\nformat ascii 1.0\nelement nothing 9223372036854775807\nelement vertex 3\n"
        "property float x\nproperty float y\nproperty float z\nelement face 1\n"
        "property list uint int vertex_indices\nend_header\n0 0 0 1 0 0 0 1 0\n"
        "4000000000 0 1 2\n",
        "more than the rest of the file can");
}

TEST_F(PlyFiles, RefusesBadValues) {
    const std::string header =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    expectRefused(header + "0 0 0 1 0 0 0 1 0\n3 0 1 3\n",
                  "meshes/bad.ply:11: face 0 uses vertex 3, but the file has 3 vertices");
    expectRefused(header + "0 0 0 1 0 0 0 1 0\n3 0 -1 2\n", "uses vertex -1");
    expectRefused(header + "0 0 0 1 nan 0 0 1 0\n3 0 1 2\n", "y of vertex 1 is nan");
    expectRefused(header + "0 0 0 1 1e39 0 0 1 0\n3 0 1 2\n", "not a finite float");
    expectRefused(header + "0 0 0 1 x 0 0 1 0\n3 0 1 2\n", "\"x\" (y of row 1) is not a number");
    expectRefused(header + "0 0 0 1 0 0 0 1 0\n2 0 1\n", "face 0 has 2 vertices");
    expectRefused(header + "0 0 0 1 0 0 0 1 0\n3 0 1 2.5\n", "not an integer");
    expectRefused(header + "0 0 0 1 0 0 0 1 0\n256 0 1 2\n", "not an integer within");
    // A well-formed file with no face in it.
    expectRefused(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0 1 0 0 0 1 0\n",
        "has no faces");
}

// A small gzip file that inflates beyond what its size allows is refused as it inflates, before
// any memory is taken for its content. The file is 256
// gzip members in a row (which gzip reads as one file), each 1 MiB of spaces; the first starts
// with a PLY header.
TEST_F(PlyFiles, RefusesAGzipBomb) {
    const std::string header =
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
        "property float z\nend_header\n";
    const std::string spaces(1 << 20, ' ');
    std::string bomb = gzipped(header + spaces);
    const std::string member = gzipped(spaces);
    for (int i = 1; i < 256; ++i) bomb += member;
    ASSERT_LT(bomb.size(), size_t(2) << 20);
    const uint64_t cap = bomb.size() * kMaxPlyInflationRatio + kPlyInflationAllowance;
    ASSERT_LT(cap, uint64_t(256) << 20);
    expectRefused(bomb, absl::StrFormat("inflates to more than %d bytes", cap));
    // Within the cap, the members make one file: two members give the sample mesh.
    const std::string mesh = sampleMesh(Format::Little);
    const size_t half = mesh.size() / 2;
    const TriangleGeometry joined =
        readPlyBytes(gzipped(mesh.substr(0, half)) + gzipped(mesh.substr(half)), "m.ply.gz");
    expectSampleGeometry(joined);
}

TEST_F(PlyFiles, RefusesWhatIsNotAFile) {
    try {
        readPlyFile((m_directory / "missing.ply").string(), "missing.ply");
        ADD_FAILURE();
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()).rfind("missing.ply: cannot open", 0), 0u) << e.what();
    }
    try {
        readPlyFile(m_directory.string(), "dir.ply");
        ADD_FAILURE();
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos);
    }
}

// The same triangles as a PLY file and as an OBJ file make the same mesh, byte for byte, through
// <mesh type="ply"> and <mesh type="obj"> under the same toWorld.
TEST_F(PlyFiles, APlyMeshIsTheSameAsTheSameObjMesh) {
    const float p[4][3] = {{0, 0, 0}, {2, 0, 0.5f}, {0, 1.5f, 0}, {2.25f, 1, -0.75f}};
    const float n[4][3] = {{0, 0, 1}, {0, 0.5f, 0.75f}, {0.5f, 0, 0.75f}, {0, 0, -1}};
    const float uv[4][2] = {{0, 0}, {1, 0}, {0, 1}, {1, 0.5f}};
    std::string obj, plyRows;
    for (int i = 0; i < 4; ++i) {
        obj += absl::StrFormat("v %g %g %g\nvn %g %g %g\nvt %g %g\n", p[i][0], p[i][1], p[i][2],
                               n[i][0], n[i][1], n[i][2], uv[i][0], uv[i][1]);
        plyRows += absl::StrFormat("%g %g %g %g %g %g %g %g\n", p[i][0], p[i][1], p[i][2], n[i][0],
                                   n[i][1], n[i][2], uv[i][0], uv[i][1]);
    }
    obj += "f 1/1/1 2/2/2 3/3/3\nf 2/2/2 4/4/4 3/3/3\n";
    plyRows += "3 0 1 2\n3 1 3 2\n";
    write("m.obj", obj);
    write("m.ply",
          gzipped("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                  "property float y\nproperty float z\nproperty float nx\nproperty float ny\n"
                  "property float nz\nproperty float s\nproperty float t\nelement face 2\n"
                  "property list uchar uint vertex_indices\nend_header\n" +
                  plyRows));
    auto scene = [&](const std::string& type) {
        const std::string path = write(type + ".xml", absl::StrFormat(R"(<scene>
<integrator type="normals"/>
<camera type="perspective"><integer name="width" value="4"/><integer name="height" value="4"/></camera>
<mesh type="%s"><string name="filename" value="m.%s"/>
  <transform name="toWorld"><scale value="2, 0.5, -3"/><rotate axis="1, 1, 0" angle="30"/><translate value="1, 2, 3"/></transform>
</mesh></scene>)",
                                                                      type, type));
        return loadScene(path);
    };
    const auto fromObj = scene("obj"), fromPly = scene("ply");
    ASSERT_EQ(fromObj->meshes().size(), 1u);
    ASSERT_EQ(fromPly->meshes().size(), 1u);
    const Mesh& a = *fromObj->meshes()[0];
    const Mesh& b = *fromPly->meshes()[0];
    EXPECT_EQ(a.positions(), b.positions());
    EXPECT_EQ(a.normals(), b.normals());
    EXPECT_EQ(a.uvs(), b.uvs());
    EXPECT_EQ(a.faces(), b.faces());
    EXPECT_EQ(b.vertexCount(), 4u);
    EXPECT_EQ(b.toString(), "mesh \"m.ply\" (4 vertices, 2 triangles)");
    EXPECT_EQ(a.surfaceArea(), b.surfaceArea());
}

TEST_F(PlyFiles, APlyMeshNamesItsFileInErrors) {
    write("bad.ply", "ply\nformat ascii 1.0\nelement vertex 1\nend_header\n");
    const std::string path = write("s.xml", R"(<scene>
<integrator type="normals"/>
<camera type="perspective"/>
<mesh type="ply"><string name="filename" value="bad.ply"/></mesh></scene>)");
    try {
        loadScene(path);
        ADD_FAILURE();
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("s.xml:4"), std::string::npos) << message;
        EXPECT_NE(message.find("(mesh type=\"ply\"): PLY file bad.ply: "), std::string::npos)
            << message;
    }
}

// A scene's PLY files are listed without reading them, and one that cannot be opened is refused
// at its element.
TEST_F(PlyFiles, AreListedAmongASceneFiles) {
    const std::string ply = write("m.ply", "not even a PLY file");
    const std::string scene = write("s.xml", R"(<scene>
<integrator type="normals"/>
<camera type="perspective"/>
<mesh type="ply"><string name="filename" value="m.ply"/></mesh></scene>)");
    const std::vector<std::string> files = listSceneFiles(scene);
    EXPECT_NE(std::find(files.begin(), files.end(), ply), files.end()) << files.size();
    fs::remove(ply);
    try {
        listSceneFiles(scene);
        ADD_FAILURE();
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("(mesh type=\"ply\"): cannot open PLY file \"m.ply\""),
                  std::string::npos)
            << message;
    }
}

// The fuzzer's seeds are valid meshes of each format: the fuzzer starts from files the reader
// accepts, and mutates from there.
TEST(PlyFuzzSeeds, AreValidMeshes) {
    auto seed = [](const std::string& name) {
        return readPlyFile(sourcePath("fuzz/corpus/ply_reader/") + name, name);
    };
    EXPECT_EQ(seed("triangle.ply").faces.cols(), 1);
    EXPECT_EQ(seed("pentagon_le.ply").faces.cols(), 3);
    const TriangleGeometry square = seed("square.ply.gz");
    EXPECT_EQ(square.faces.cols(), 2);
    EXPECT_EQ(square.positions.col(2), Eigen::Vector3f(1, 1, 0));
    const TriangleGeometry little = seed("cube_le.ply"), big = seed("cube_be.ply");
    EXPECT_TRUE(same(little, big));
    ASSERT_EQ(little.faces.cols(), 12);
    EXPECT_EQ(little.uvs.cols(), 8);
    // A closed cube, consistently wound: one level of subdivision adds a vertex per edge.
    const TriangleGeometry subdivided = loopSubdivide(little.positions, little.faces, 1, "cube");
    EXPECT_EQ(subdivided.positions.cols(), 8 + 18);
    EXPECT_EQ(subdivided.faces.cols(), 48);
}

}  // namespace
}  // namespace alphorn
