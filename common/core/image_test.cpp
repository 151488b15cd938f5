#include "common/core/image.h"

#include "common/core/error.h"
#include "common/scene/parser.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cstring>
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

// The coordinator sends images encoded in memory (its disk may be full or read-only) and
// promises them byte-identical to the files `alphorn render` writes: the encoders give the
// files' bytes, for EXR and for PNG at several exposures.
TEST(ImageFiles, ImagesEncodedInMemoryAreTheFilesBytes) {
    const fs::path directory = freshDirectory("image_files_encoded");
    const Image image = noise(37, 23);
    writeEXR((directory / "a.exr").string(), image);
    EXPECT_EQ(encodeEXR(image), contents(directory / "a.exr"));
    for (const float exposure : {0.0f, 1.5f, -3.0f}) {
        writePNG((directory / "a.png").string(), image, exposure);
        EXPECT_EQ(encodePNG(image, exposure), contents(directory / "a.png")) << exposure;
    }
    EXPECT_EQ(readEXR((directory / "a.exr").string()).rgb, image.rgb);
    fs::remove_all(directory);
}

// PNG's CRC-32 (ISO 3309), for patching a chunk.
uint32_t crc32(const std::string& bytes) {
    uint32_t crc = 0xffffffffu;
    for (const char c : bytes) {
        crc ^= static_cast<unsigned char>(c);
        for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

void putBigEndian(std::string& bytes, size_t offset, uint32_t value) {
    for (int i = 0; i < 4; ++i) bytes[offset + i] = char(value >> (24 - 8 * i));
}

// A PNG of a few hundred bytes whose header claims 12000 x 12000 pixels (its IHDR chunk
// rewritten, with a valid CRC), within the pixel limit but far beyond what its data can hold, is
// refused before memory is allocated for the image (reading it took 1.8 GB and 20 s); one
// claiming 60000 x 60000 is refused by the pixel limit.
TEST(ImageFiles, ASmallFileClaimingAHugeImageIsRefused) {
    const fs::path directory = freshDirectory("image_files_bomb");
    const fs::path path = directory / "bomb.png";
    writePNG(path.string(), noise(4, 4));
    std::string bytes = contents(path);
    ASSERT_EQ(bytes.substr(12, 4), "IHDR");
    for (const auto& [size, expected] :
         {std::pair<uint32_t, std::string>{12000, "the header declares a 12000x12000 image"},
          {60000, "the image is 60000x60000 pixels, more than the 268435456"}}) {
        putBigEndian(bytes, 16, size);
        putBigEndian(bytes, 20, size);
        putBigEndian(bytes, 29, crc32(bytes.substr(12, 17)));
        std::ofstream(path, std::ios::binary) << bytes;
        try {
            readPNG(path.string());
            ADD_FAILURE() << "the crafted PNG was read";
        } catch (const Error& e) {
            const std::string message = e.what();
            EXPECT_NE(message.find("bomb.png: " + expected), std::string::npos) << message;
            // Only the pixel limit is a limit; the other is a broken file.
            EXPECT_EQ(dynamic_cast<const ResourceLimitError*>(&e) != nullptr, size == 60000)
                << message;
        }
    }
    // A bitmap texture naming the image beyond the pixel limit is refused the same way, at its
    // element (the farm answers RESOURCE_EXHAUSTED).
    std::ofstream(directory / "scene.xml") << R"(<scene>
<integrator type="normals"/><camera type="perspective"/>
<mesh type="obj"><string name="filename" value="none.obj"/><bsdf type="diffuse">
<texture type="bitmap" name="albedo"><string name="filename" value="bomb.png"/></texture>
</bsdf></mesh></scene>)";
    try {
        parseSceneFile((directory / "scene.xml").string());
        ADD_FAILURE() << "a texture beyond the pixel limit was loaded";
    } catch (const ResourceLimitError& e) {
        EXPECT_NE(std::string(e.what()).find("scene.xml:4:"), std::string::npos) << e.what();
    }
    fs::remove_all(directory);
}

TEST(ImageFiles, DeclaredSizesBeyondTheLimitOrTheFilesCompressionAreRefused) {
    EXPECT_NO_THROW(checkDeclaredImageSize("a.exr", 16384, 16384, 2u << 28, 1u << 20));
    EXPECT_THROW(checkDeclaredImageSize("a.exr", 16385, 16384, 2u << 28, 1u << 30), Error);
    EXPECT_NO_THROW(checkDeclaredImageSize("a.png", 100, 100, 1100 * 50, 50));
    EXPECT_THROW(checkDeclaredImageSize("a.png", 100, 100, 1100 * 50 + 1, 50), Error);
}

// The bytes of one float in the given byte order.
std::string floatBytes(float v, bool littleEndian) {
    uint32_t bits;
    std::memcpy(&bits, &v, 4);
    std::string out(4, '\0');
    for (int i = 0; i < 4; ++i) out[littleEndian ? i : 3 - i] = char((bits >> (8 * i)) & 0xff);
    return out;
}

// PFM stores rows bottom to top; either byte order (the scale's sign) and grey ("Pf") files read.
TEST(ImageFiles, PFMRowsByteOrderAndGreyAreRead) {
    const fs::path directory = freshDirectory("image_files_pfm");
    for (const bool little : {true, false}) {
        // A 2x2 RGB map; the file's first row is the image's bottom row.
        std::string rgb = std::string("PF\n2 2\n") + (little ? "-1.0" : "1.0") + "\n";
        for (float v : {1.f, 2.f, 3.f, 4.f, 5.f, 6.f, 7.f, 8.f, 9.f, 10.f, 11.f, 12.f})
            rgb += floatBytes(v, little);
        std::ofstream(directory / "rgb.pfm", std::ios::binary) << rgb;
        const Image image = readPFM((directory / "rgb.pfm").string());
        ASSERT_EQ(image.width, 2);
        ASSERT_EQ(image.height, 2);
        EXPECT_TRUE((image.get(0, 1) == Color3f(1.f, 2.f, 3.f)).all())
            << image.get(0, 1).toString();
        EXPECT_TRUE((image.get(1, 1) == Color3f(4.f, 5.f, 6.f)).all())
            << image.get(1, 1).toString();
        EXPECT_TRUE((image.get(0, 0) == Color3f(7.f, 8.f, 9.f)).all())
            << image.get(0, 0).toString();
        EXPECT_TRUE((image.get(1, 0) == Color3f(10.f, 11.f, 12.f)).all())
            << image.get(1, 0).toString();

        std::string grey = std::string("Pf 3 1 ") + (little ? "-2" : "0.5") + "\n";
        for (float v : {0.25f, -1.5f, 8.0f}) grey += floatBytes(v, little);
        std::ofstream(directory / "grey.pfm", std::ios::binary) << grey;
        const Image g = readPFM((directory / "grey.pfm").string());
        ASSERT_EQ(g.width, 3);
        ASSERT_EQ(g.height, 1);
        EXPECT_TRUE((g.get(1, 0) == Color3f(-1.5f)).all()) << g.get(1, 0).toString();
        EXPECT_TRUE((g.get(2, 0) == Color3f(8.0f)).all()) << g.get(2, 0).toString();
    }
    // writePFM's file reads back as the image it wrote.
    Image written = noise(5, 3);
    writePFM((directory / "noise.pfm").string(), written);
    EXPECT_EQ(readPFM((directory / "noise.pfm").string()).rgb, written.rgb);
    fs::remove_all(directory);
}

// A file that does not hold what its header declares is refused, naming the file; so are
// malformed headers.
TEST(ImageFiles, MalformedPFMsAreRefused) {
    const fs::path directory = freshDirectory("image_files_bad_pfm");
    const std::string path = (directory / "bad.pfm").string();
    auto expectRefused = [&](const std::string& bytes, const std::string& expected) {
        std::ofstream(path, std::ios::binary) << bytes;
        try {
            readPFM(path);
            ADD_FAILURE() << "read: " << expected;
        } catch (const Error& e) {
            const std::string message = e.what();
            EXPECT_NE(message.find("bad.pfm: " + expected), std::string::npos) << message;
        }
    };
    const std::string twelve = std::string(12 * 4, '\0');
    expectRefused("PF\n2 2\n-1\n" + twelve.substr(0, 40), "the PFM header declares 2x2");
    expectRefused("PF\n2 2\n-1\n" + twelve + "xx", "the PFM header declares 2x2");
    expectRefused("P6\n2 2\n255\n", "not a PFM file");
    expectRefused("PF\n-2 2\n-1\n" + twelve, "the PFM header has no valid positive width");
    expectRefused("PF\n2 2\n0\n" + twelve, "the PFM header's scale");
    expectRefused("PF\n2 2\nabc\n" + twelve, "the PFM header's scale");
    expectRefused("PF\n60000 60000\n-1\n" + twelve, "the image is 60000x60000 pixels");
    fs::remove_all(directory);
}

}  // namespace
}  // namespace alphorn
