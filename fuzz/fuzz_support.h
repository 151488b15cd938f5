// What the harnesses share: a private scratch directory for inputs that the code under test
// reads by path, and silencing of the loader's warnings (millions of them slow a session down).
#pragma once

#include "common/scene/accel.h"

#include <unistd.h>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>
#include <string_view>

namespace alphorn::fuzz {

// A directory of this process (under $TMPDIR or /tmp), removed when the process exits normally.
inline const std::string& scratchDirectory() {
    static const std::string directory = [] {
        const char* base = std::getenv("TMPDIR");
        std::string pattern = std::string(base && *base ? base : "/tmp") + "/alphorn-fuzz-XXXXXX";
        if (!mkdtemp(pattern.data())) throw std::runtime_error("cannot create " + pattern);
        static const std::string removeAtExit = pattern;
        std::atexit([] {
            std::error_code ignored;
            std::filesystem::remove_all(removeAtExit, ignored);
        });
        return pattern;
    }();
    return directory;
}

inline void writeFile(const std::string& path, std::string_view bytes) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out) throw std::runtime_error("cannot write " + path);
}

inline std::string_view asText(const uint8_t* data, size_t size) {
    return {reinterpret_cast<const char*>(data), size};
}

// The scene loader reports unused properties on std::cerr; sanitizer and libFuzzer reports go
// to file descriptor 2 directly and are not affected.
inline void silenceWarnings() {
    static std::ofstream devNull("/dev/null");
    std::cerr.rdbuf(devNull.rdbuf());
}

// Runs a built mesh through what rendering does with one: Embree's BVH over it, a ray at it from
// outside its bounds, and a point sampled on it (when it has area).
inline void traceAndSample(const std::shared_ptr<Mesh>& mesh) {
    Accel accel;
    accel.build({mesh});
    const Eigen::AlignedBox3f box = mesh->bounds();
    const Point3f target = box.center();
    const Point3f origin = target + Vector3f(0.3f, 0.7f, 1.0f) * (box.diagonal().norm() + 1.0f);
    Ray3f ray(origin, (target - origin).normalized());
    Intersection its;
    accel.intersect(ray, its);
    if (mesh->surfaceArea() > 0.0f) mesh->sampleSurface(Point2f(0.37f, 0.61f));
}

}  // namespace alphorn::fuzz

namespace alphorn::fuzz {

// film_codec inputs: 4 bytes choose the block the coordinator expects (as a lease would), the
// rest is the compressed film a worker sent.
struct FilmShape {
    int x0, y0, width, height;
};
constexpr size_t kFilmHeaderBytes = 4;
inline FilmShape filmShapeFromHeader(const uint8_t* header) {
    return {int8_t(header[2]), int8_t(header[3]), 1 + header[0] % 32, 1 + header[1] % 32};
}

// checkpoint inputs: 4 bytes choose the job the coordinator expects (width, height, unit count)
// and whether to append the file's SHA-256 trailer, which the fuzzer cannot compute, so that
// mutations reach the parser behind the checksum; the rest is the checkpoint file before it.
struct CheckpointShape {
    int width, height;
    uint32_t units;
    bool appendChecksum;
};
constexpr size_t kCheckpointHeaderBytes = 4;
// The owner the corpus's checkpoints are written for and the fuzzer reads them as.
inline constexpr const char* kCheckpointOwner = "job 1";
inline CheckpointShape checkpointShapeFromHeader(const uint8_t* header) {
    return {1 + header[0] % 16, 1 + header[1] % 16, header[2], (header[3] & 1) != 0};
}
}  // namespace alphorn::fuzz
