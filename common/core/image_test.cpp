#include "common/core/image.h"

#include "common/core/error.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

namespace alphorn {
namespace {

namespace fs = std::filesystem;

fs::path freshDirectory(const std::string& name) {
    const fs::path path =
        fs::temp_directory_path() / ("alphorn_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
    return path;
}

std::string contents(const fs::path& path) {
    std::ifstream file(path, std::ios::binary);
    std::ostringstream bytes;
    bytes << file.rdbuf();
    return bytes.str();
}

// A noisy image: ZIP compression cannot shrink it below the file size limit used here.
Image noise(int width, int height) {
    Image image(width, height);
    uint32_t state = 12345;
    for (float& v : image.rgb) {
        state = state * 1664525u + 1013904223u;
        v = float(state >> 8) / float(1u << 24);
    }
    return image;
}

// Runs `write` with writes beyond `bytes` per file failing (EFBIG, as a full disk fails them),
// then lifts the limit again.
void withFileSizeLimit(rlim_t bytes, const std::function<void()>& write) {
    rlimit saved{};
    ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &saved), 0);
    rlimit limited = saved;
    limited.rlim_cur = bytes;
    ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &limited), 0);
    // Without this the kernel would end the process with SIGXFSZ instead of failing the write.
    struct sigaction ignore = {}, previous = {};
    ignore.sa_handler = SIG_IGN;
    sigaction(SIGXFSZ, &ignore, &previous);
    write();
    setrlimit(RLIMIT_FSIZE, &saved);
    sigaction(SIGXFSZ, &previous, nullptr);
}

bool onlyFileIs(const fs::path& directory, const fs::path& file) {
    for (const auto& entry : fs::directory_iterator(directory))
        if (entry.path() != file) return false;
    return true;
}

// A write that fails part way (here at a file size limit, as on a full disk) throws an Error
// naming the file, keeps the earlier file at the path byte for byte, and leaves no partial file.
TEST(ImageFiles, AFailedWriteKeepsTheEarlierFileAndLeavesNoPartialOne) {
    const fs::path directory = freshDirectory("image_files_failed");
    const Image image = noise(96, 96);  // 108 KiB of floats, ~100 KiB as EXR, ~27 KiB as PNG
    for (const bool exr : {true, false}) {
        const fs::path path = directory / (exr ? "a.exr" : "a.png");
        std::ofstream(path) << "the earlier image";
        bool failed = false;
        withFileSizeLimit(8192, [&] {
            try {
                exr ? writeEXR(path.string(), image) : writePNG(path.string(), image);
            } catch (const Error& error) {
                failed = true;
                EXPECT_NE(std::string(error.what()).find(path.string()), std::string::npos)
                    << error.what();
            }
        });
        EXPECT_TRUE(failed) << path << " was written past the file size limit";
        EXPECT_EQ(contents(path), "the earlier image") << path;
        EXPECT_TRUE(onlyFileIs(directory, path)) << "a partial file was left beside " << path;
        fs::remove(path);
    }
    fs::remove_all(directory);
}

// A write that succeeds replaces the earlier file whole.
TEST(ImageFiles, ASuccessfulWriteReplacesTheEarlierFile) {
    const fs::path directory = freshDirectory("image_files_replaced");
    const fs::path path = directory / "a.exr";
    std::ofstream(path) << "the earlier image";
    const Image image = noise(16, 8);
    writeEXR(path.string(), image);
    const Image read = readEXR(path.string());
    EXPECT_EQ(read.rgb, image.rgb);
    EXPECT_TRUE(onlyFileIs(directory, path));
    fs::remove_all(directory);
}

}  // namespace
}  // namespace alphorn
