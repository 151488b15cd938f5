// What instancing saves: one mesh of about 100k triangles placed INSTANCES times (one group, one
// BVH, an Embree instance per placement) against the same mesh copied flat, each copy a mesh of
// its own in the scene's BVH, measured in the same run.
//
// Each variant is built in a child process of its own, from the same generated vertex arrays
// (made before the measurement starts), and reports the growth of the resident set: its peak
// (VmHWM, which takes in Embree's working memory while it builds) and what stays resident once
// built (VmRSS). A process cannot hold 1000 flat copies here (about 16 GB), so the flat figure
// is measured on FLAT copies and taken per copy; the ratio printed is the instanced scene's
// memory over FLAT-copy memory scaled to INSTANCES copies. The per-instance bytes are the
// difference between INSTANCES placements and one, over INSTANCES - 1.
//
// usage: bench_instancing_memory [INSTANCES] [FLAT] [GRID]
//   INSTANCES: placements of the mesh (default 1000); FLAT: flat copies measured (default 8);
//   GRID: the mesh is a GRID x GRID latitude-longitude sphere of 2 GRID^2 triangles (default 224,
//   100,352 triangles), with vertex normals.
#include "common/scene/accel.h"
#include "common/scene/instance.h"

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

using namespace alphorn;

namespace {

// A kB figure ("VmHWM:", "VmRSS:") of /proc/self/status, in bytes.
uint64_t statusBytes(const std::string& key) {
    std::ifstream status("/proc/self/status");
    std::string line;
    while (std::getline(status, line))
        if (line.rfind(key, 0) == 0) return 1024 * std::stoull(line.substr(key.size()));
    std::fprintf(stderr, "no %s in /proc/self/status\n", key.c_str());
    std::exit(1);
}

struct Geometry {
    Eigen::Matrix<float, 3, Eigen::Dynamic> positions, normals;
    Eigen::Matrix<uint32_t, 3, Eigen::Dynamic> faces;
};

// A unit sphere of grid x grid quads (two triangles each) in latitude and longitude.
Geometry sphere(int grid) {
    Geometry g;
    const int columns = grid + 1, rows = grid + 1;
    g.positions.resize(3, size_t(columns) * rows);
    for (int r = 0; r < rows; ++r)
        for (int c = 0; c < columns; ++c) {
            const float theta = float(M_PI) * float(r) / float(grid);
            const float phi = 2.0f * float(M_PI) * float(c) / float(grid);
            g.positions.col(size_t(r) * columns + c) = Point3f(
                std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
        }
    g.normals = g.positions;
    g.faces.resize(3, 2 * size_t(grid) * grid);
    size_t f = 0;
    for (int r = 0; r < grid; ++r)
        for (int c = 0; c < grid; ++c) {
            const uint32_t a = r * columns + c, b = a + 1, d = a + columns, e = d + 1;
            g.faces.col(f++) = Eigen::Matrix<uint32_t, 3, 1>(a, d, b);
            g.faces.col(f++) = Eigen::Matrix<uint32_t, 3, 1>(b, d, e);
        }
    return g;
}

// The generated geometry as a scene mesh, moved by `offset` (a flat copy's own vertices).
class GeneratedMesh : public Mesh {
  public:
    GeneratedMesh(const Geometry& g, const Vector3f& offset) {
        m_name = "generated sphere";
        Eigen::Matrix<float, 3, Eigen::Dynamic> positions = g.positions.colwise() + offset;
        setGeometry(std::move(positions), g.normals, {}, g.faces);
        activate();
    }
};

Vector3f placement(int i) {
    return Vector3f(3.0f * float(i % 32), 0.0f, -3.0f * float(i / 32));
}

struct Growth {
    double peak = 0, resident = 0;  // bytes
};

// Builds `flat` flat copies, or one group placed `instances` times, in a child process; returns
// the growth of its peak and resident memory over the generated arrays alone.
Growth measure(const Geometry& geometry, int flat, int instances) {
    int channel[2];
    if (pipe(channel) != 0) {
        std::perror("pipe");
        std::exit(1);
    }
    const pid_t child = fork();
    if (child < 0) {
        std::perror("fork");
        std::exit(1);
    }
    if (child == 0) {
        close(channel[0]);
        const double before = double(statusBytes("VmRSS:"));
        std::vector<std::shared_ptr<Mesh>> meshes;
        std::vector<Instance> placed;
        for (int i = 0; i < flat; ++i)
            meshes.push_back(std::make_shared<GeneratedMesh>(geometry, placement(i)));
        if (instances > 0) {
            auto group = std::make_shared<MeshGroup>("sphere");
            group->addMesh(std::make_shared<GeneratedMesh>(geometry, Vector3f::Zero()));
            placed.reserve(instances);
            for (int i = 0; i < instances; ++i) {
                Eigen::Affine3f m = Eigen::Affine3f::Identity();
                m.translate(placement(i));
                m.rotate(Eigen::AngleAxisf(0.1f * float(i), Vector3f::UnitY()));
                placed.emplace_back(group, Transform(m.matrix()));
            }
        }
        Accel accel;
        accel.build(meshes, placed);
        // One ray, so that nothing is left unbuilt or lazily allocated.
        Intersection its;
        accel.intersect(Ray3f(Point3f(0.1f, 5.0f, 0.1f), Vector3f(0.0f, -1.0f, 0.0f)), its);
        const Growth growth{double(statusBytes("VmHWM:")) - before,
                            double(statusBytes("VmRSS:")) - before};
        const bool written =
            write(channel[1], &growth, sizeof growth) == static_cast<ssize_t>(sizeof growth);
        _exit(written ? 0 : 1);
    }
    close(channel[1]);
    Growth growth;
    const bool read = ::read(channel[0], &growth, sizeof growth) == sizeof growth;
    close(channel[0]);
    int status = 0;
    waitpid(child, &status, 0);
    if (!read || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        std::fprintf(stderr, "the measuring process failed\n");
        std::exit(1);
    }
    return growth;
}

}  // namespace

int main(int argc, char** argv) {
    const int instances = argc > 1 ? std::atoi(argv[1]) : 1000;
    const int flat = argc > 2 ? std::atoi(argv[2]) : 8;
    const int grid = argc > 3 ? std::atoi(argv[3]) : 224;
    if (instances < 2 || flat < 1 || grid < 2 || grid > 4096) {
        std::fprintf(stderr, "usage: bench_instancing_memory [INSTANCES>=2] [FLAT>=1] [GRID]\n");
        return 2;
    }
    const Geometry geometry = sphere(grid);
    const double triangles = double(geometry.faces.cols());
    std::printf("mesh: %.0f triangles, %ld vertices (with normals)\n", triangles,
                long(geometry.positions.cols()));

    const Growth copies = measure(geometry, flat, 0);
    const Growth one = measure(geometry, 0, 1);
    const Growth many = measure(geometry, 0, instances);
    const double MB = 1e6;
    std::printf("flat, %d copies:           peak +%8.1f MB, resident +%8.1f MB (%.1f MB a copy)\n",
                flat, copies.peak / MB, copies.resident / MB, copies.resident / flat / MB);
    std::printf("instanced, 1 placement:    peak +%8.1f MB, resident +%8.1f MB\n", one.peak / MB,
                one.resident / MB);
    std::printf("instanced, %d placements: peak +%8.1f MB, resident +%8.1f MB\n", instances,
                many.peak / MB, many.resident / MB);
    std::printf("per instance: %.0f bytes resident, %.0f bytes peak (%.0f B a triangle flat)\n",
                (many.resident - one.resident) / (instances - 1),
                (many.peak - one.peak) / (instances - 1), copies.resident / flat / triangles);
    std::printf(
        "ratio, %d placements against %d flat copies (flat per copy x %d): resident %.5f, "
        "peak %.5f\n",
        instances, instances, instances, many.resident / (copies.resident / flat * instances),
        many.peak / (copies.peak / flat * instances));
    return 0;
}
