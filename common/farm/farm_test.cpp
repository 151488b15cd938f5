// Unit tests of the farm's shared pieces: bundle path rules, the unit grid, film compression,
// hashing and atomic writes.
#include "common/core/error.h"
#include "common/farm/bundle.h"
#include "common/farm/files.h"
#include "common/farm/film_codec.h"
#include "common/farm/job_grid.h"
#include "common/farm/rpc.h"
#include "common/farm/sha256.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>

namespace alphorn::farm {
namespace {

TEST(Sha256, KnownDigests) {
    EXPECT_EQ(sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
    EXPECT_EQ(sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    Sha256 incremental;
    incremental.update("a");
    incremental.update("bc");
    EXPECT_EQ(incremental.finishHex(), sha256Hex("abc"));
    EXPECT_TRUE(isSha256Hex(sha256Hex("x")));
    EXPECT_FALSE(isSha256Hex("../etc/passwd"));
    EXPECT_FALSE(isSha256Hex(std::string(64, 'A')));
}

TEST(BundlePath, RefusesEscapes) {
    EXPECT_NO_THROW(validateBundlePath("scene.xml"));
    EXPECT_NO_THROW(validateBundlePath("meshes/cube.obj"));
    EXPECT_THROW(validateBundlePath("/etc/passwd"), Error);
    EXPECT_THROW(validateBundlePath("../x.obj"), Error);
    EXPECT_THROW(validateBundlePath("a/../../x.obj"), Error);
    EXPECT_THROW(validateBundlePath("a/.."), Error);
    EXPECT_THROW(validateBundlePath("a//b"), Error);
    EXPECT_THROW(validateBundlePath("./a"), Error);
    EXPECT_THROW(validateBundlePath(""), Error);
    EXPECT_THROW(validateBundlePath("a\\..\\b"), Error);
}

TEST(Bundle, ValidatesManifest) {
    Bundle bundle;
    bundle.scenePath = "s.xml";
    bundle.files.push_back({"s.xml", sha256Hex("a"), 1, ""});
    EXPECT_NO_THROW(validateBundle(bundle));
    bundle.files.push_back({"s.xml", sha256Hex("b"), 1, ""});
    EXPECT_THROW(validateBundle(bundle), Error);  // duplicate
    bundle.files.back() = {"m", "nothex", 1, ""};
    EXPECT_THROW(validateBundle(bundle), Error);
    bundle.files.back() = {"s.xml/inner", sha256Hex("b"), 1, ""};
    EXPECT_THROW(validateBundle(bundle), Error);  // file and directory
    bundle.files.pop_back();
    bundle.scenePath = "other.xml";
    EXPECT_THROW(validateBundle(bundle), Error);
}

TEST(Bundle, GatherAndMaterializeRoundTrip) {
    namespace fs = std::filesystem;
    const fs::path root =
        fs::temp_directory_path() / ("alphorn_bundle_test_" + std::to_string(::getpid()));
    fs::remove_all(root);
    fs::create_directories(root / "scenes" / "sub");
    fs::copy_file(sourcePath("scenes/meshes/quad.obj"), root / "scenes/quad.obj");
    // The scene sits in a subdirectory and reaches up with "..": the bundle root moves up.
    std::ofstream(root / "scenes/sub/s.xml") << R"(<scene>
  <integrator type="normals"/>
  <camera type="perspective"><integer name="width" value="8"/><integer name="height" value="8"/></camera>
  <mesh type="obj"><string name="filename" value="../quad.obj"/></mesh>
</scene>)";
    Bundle bundle = gatherBundle((root / "scenes/sub/s.xml").string());
    EXPECT_EQ(bundle.scenePath, "sub/s.xml");
    ASSERT_EQ(bundle.files.size(), 2u);
    EXPECT_EQ(bundle.files[0].path, "quad.obj");
    EXPECT_EQ(bundle.files[0].sha256, sha256OfFile((root / "scenes/quad.obj").string()));
    std::map<std::string, std::string> blobs;
    for (const BundleEntry& entry : bundle.files) blobs[entry.sha256] = entry.sourcePath;
    const std::string scene = materializeBundle(
        bundle, (root / "out").string(), [&](const std::string& sha) { return blobs.at(sha); });
    EXPECT_EQ(scene, (root / "out/sub/s.xml").string());
    EXPECT_EQ(readFile((root / "out/quad.obj").string()),
              readFile((root / "scenes/quad.obj").string()));
    fs::remove_all(root);
}

TEST(JobGrid, CoversEveryPassAndPixelOnce) {
    JobGrid grid(TileGrid(100, 70, 32, 2), 7, 3);
    EXPECT_EQ(grid.tileCount(), 4u * 3u);
    EXPECT_EQ(grid.chunkCount(), 3u);
    std::vector<int> coverage(100 * 70 * 7, 0);
    for (uint32_t i = 0; i < grid.unitCount(); ++i) {
        RenderUnit unit = grid.unit(i);
        EXPECT_EQ(grid.chunkOf(i), unit.passBegin / 3);
        for (uint32_t p = unit.passBegin; p < unit.passEnd; ++p)
            for (int y = unit.tile.y0; y < unit.tile.y1; ++y)
                for (int x = unit.tile.x0; x < unit.tile.x1; ++x)
                    ++coverage[(p * 70 + y) * 100 + x];
    }
    for (int c : coverage) ASSERT_EQ(c, 1);
    EXPECT_THROW(grid.unit(grid.unitCount()), Error);
    std::vector<bool> merged(grid.unitCount(), false);
    EXPECT_EQ(grid.passesComplete(merged), 0u);
    for (uint32_t t = 0; t < grid.tileCount(); ++t) merged[2 * grid.tileCount() + t] = true;
    EXPECT_EQ(grid.passesComplete(merged), 1u);  // the last chunk holds pass 6 only
    EXPECT_THROW(JobGrid(TileGrid(0, 1, 1, 1), 1, 1), Error);
    EXPECT_THROW(JobGrid(TileGrid(1, 1, 1, 1), 0, 1), Error);
    EXPECT_THROW(JobGrid(TileGrid(), 1, 1), Error) << "no tiles";
}

// Counts that overflowed 32 bits gave a job of zero units (shown done with a black image) or
// an index past the end of the merged flags (a crash at every status call).
TEST(JobGrid, CountsNeverWrap) {
    const JobGrid oneChunk(TileGrid(64, 64, 64, 1), 3, UINT32_MAX);
    EXPECT_EQ(oneChunk.chunkCount(), 1u);
    EXPECT_EQ(oneChunk.unitCount(), 1u);
    EXPECT_EQ(oneChunk.unit(0).passBegin, 0u);
    EXPECT_EQ(oneChunk.unit(0).passEnd, 3u);
    EXPECT_EQ(oneChunk.passesComplete({true}), 3u);
    const JobGrid lastChunk(TileGrid(1, 1, 1, 1), UINT32_MAX, UINT32_MAX - 1);
    EXPECT_EQ(lastChunk.unitCount(), 2u);
    EXPECT_EQ(lastChunk.unit(1).passBegin, UINT32_MAX - 1);
    EXPECT_EQ(lastChunk.unit(1).passEnd, UINT32_MAX);
    EXPECT_EQ(lastChunk.chunkPasses(1), 1u);
    // 4096 one-pixel tiles x 2^20 passes = 2^32 units: refused, not wrapped to 0.
    EXPECT_THROW(JobGrid(TileGrid(64, 64, 1, 1), 1u << 20, 1), Error);
    EXPECT_EQ(JobGrid(TileGrid(64, 64, 1, 1), (1u << 20) - 1, 1).unitCount(),
              4096u * ((1u << 20) - 1));
    EXPECT_THROW(oneChunk.passesComplete({true, false}), Error);
}

TEST(FilmCodec, RoundTripIsExact) {
    FilmBlock block(-2, -3, 40, 30);
    for (int y = -3; y < 27; ++y)
        for (int x = -2; x < 38; ++x) {
            PixelSum& p = block.at(x, y);
            p.rgb[0] = FixedPoint(x * 1000003 + y) << 70;
            p.rgb[1] = -FixedPoint(y);
            p.weight = FixedPoint(1) << 40;
        }
    std::string compressed = compressFilm(block);
    FilmBlock back(-2, -3, 40, 30);
    decompressFilm(compressed, back);
    EXPECT_EQ(back.serialize(), block.serialize());
    FilmBlock wrongShape(0, 0, 10, 10);
    EXPECT_THROW(decompressFilm(compressed, wrongShape), Error);
    EXPECT_THROW(decompressFilm("garbage", back), Error);
}

TEST(Files, AtomicWriteReplaces) {
    const std::string path =
        (std::filesystem::temp_directory_path() / ("alphorn_atomic_" + std::to_string(::getpid())))
            .string();
    writeFileAtomically(path, "one");
    writeFileAtomically(path, "two");
    EXPECT_EQ(readFile(path), "two");
    std::filesystem::remove(path);
}

TEST(Tokens, GeneratedAndCheckedByLength) {
    std::set<std::string> tokens{generateToken(), generateToken()};
    EXPECT_EQ(tokens.size(), 2u);
    EXPECT_EQ(tokens.begin()->size(), 64u);
    const std::string path =
        (std::filesystem::temp_directory_path() / ("alphorn_token_" + std::to_string(::getpid())))
            .string();
    writeFileAtomically(path, "short\n");
    EXPECT_THROW(readTokenFile(path), Error);
    writeFileAtomically(path, "  0123456789abcdef0123  \nignored");
    EXPECT_EQ(readTokenFile(path), "0123456789abcdef0123");
    std::filesystem::remove(path);
}

}  // namespace
}  // namespace alphorn::farm
