#include "coordinator/checkpoint.h"

#include "common/core/error.h"
#include "common/farm/files.h"
#include "common/farm/film_codec.h"
#include "common/farm/metrics.h"
#include "common/farm/sha256.h"

#include <cstring>

namespace alphorn::coordinator {

namespace {

// Layout: magic (its last byte is the version), u32 width, u32 height, u32 units, u64 invalid
// samples, [version 2 and later: one byte, 1 when the film keeps its odd passes' half],
// [version 3 and later: one byte, 1 when it keeps the smaller radius's image], [version 4: u32
// owner length, the owner], one byte per unit, u64 compressed film size, compressed film, then
// the SHA-256 (hex) of everything before it.
// Version 1 (before the pass halves) is read as a film without halves: the job goes on, and its
// image has no error estimate. Version 2 (before the smaller radius) is read as a film without
// the smaller radius's image, as jobs of that time were.
constexpr char kMagic[7] = {'A', 'L', 'P', 'H', 'C', 'K', 'P'};
constexpr char kVersionWithoutHalves = '1', kVersionWithoutSmallerRadius = '2',
               kVersionWithoutOwner = '3', kVersion = '4';

template <typename T>
void put(std::string& out, T value) {
    out.append(reinterpret_cast<const char*>(&value), sizeof value);
}

template <typename T>
T take(const std::string& in, size_t& offset) {
    if (offset + sizeof(T) > in.size()) fail("checkpoint is truncated");
    T value;
    std::memcpy(&value, in.data() + offset, sizeof value);
    offset += sizeof value;
    return value;
}

}  // namespace

void writeCheckpoint(const std::string& path, const std::string& owner, const FilmBlock& film,
                     const std::vector<bool>& merged) {
    const farm::Stopwatch stopwatch;
    std::string out(kMagic, sizeof kMagic);
    out.push_back(kVersion);
    put<uint32_t>(out, static_cast<uint32_t>(film.width()));
    put<uint32_t>(out, static_cast<uint32_t>(film.height()));
    put<uint32_t>(out, static_cast<uint32_t>(merged.size()));
    put<uint64_t>(out, film.invalidSamples);
    put<uint8_t>(out, film.keepsHalves() ? 1 : 0);
    put<uint8_t>(out, film.keepsSmallerRadius() ? 1 : 0);
    put<uint32_t>(out, static_cast<uint32_t>(owner.size()));
    out += owner;
    for (bool m : merged) out.push_back(m ? 1 : 0);
    const std::string compressed = farm::compressFilm(film);
    put<uint64_t>(out, compressed.size());
    out += compressed;
    out += farm::sha256Hex(out);
    farm::writeFileAtomically(path, out);
    farm::CoordinatorMetrics::checkpointWritten(stopwatch.seconds(), out.size());
}

Checkpoint readCheckpoint(const std::string& path, const std::string& owner, int width, int height,
                          uint32_t unitCount) {
    const std::string in = farm::readFile(path);
    if (in.size() < sizeof kMagic + 1 + 64 || std::memcmp(in.data(), kMagic, sizeof kMagic) != 0)
        fail("%s: not an Alphorn checkpoint", path);
    const char version = in[sizeof kMagic];
    if (version < kVersionWithoutHalves || version > kVersion)
        fail("%s: checkpoint version %c is not one this Alphorn reads (1 to 4)", path, version);
    const std::string body = in.substr(0, in.size() - 64);
    if (farm::sha256Hex(body) != in.substr(in.size() - 64))
        fail("%s: checkpoint checksum mismatch", path);
    size_t offset = sizeof kMagic + 1;
    const uint32_t w = take<uint32_t>(body, offset), h = take<uint32_t>(body, offset);
    const uint32_t units = take<uint32_t>(body, offset);
    if (int(w) != width || int(h) != height || units != unitCount)
        fail("%s: checkpoint is for a %ux%u image with %u units, expected %dx%d with %u", path, w,
             h, units, width, height, unitCount);
    Checkpoint checkpoint;
    const uint64_t invalid = take<uint64_t>(body, offset);
    PassHalves halves = PassHalves::None;
    if (version >= kVersionWithoutSmallerRadius) {
        const uint8_t kept = take<uint8_t>(body, offset);
        if (kept > 1) fail("%s: checkpoint has an invalid pass-halves flag %u", path, kept);
        halves = kept ? PassHalves::Kept : PassHalves::None;
    }
    SmallerRadius smallerRadius = SmallerRadius::None;
    if (version >= kVersionWithoutOwner) {
        const uint8_t kept = take<uint8_t>(body, offset);
        if (kept > 1) fail("%s: checkpoint has an invalid smaller-radius flag %u", path, kept);
        smallerRadius = kept ? SmallerRadius::Kept : SmallerRadius::None;
    }
    if (version >= kVersion) {
        const uint32_t length = take<uint32_t>(body, offset);
        if (length > body.size() - offset) fail("%s: checkpoint is truncated", path);
        const std::string written = body.substr(offset, length);
        offset += length;
        if (written != owner)
            fail("%s: the checkpoint belongs to %s, not to %s", path, written, owner);
    }
    if (offset + units > body.size()) fail("%s: checkpoint is truncated", path);
    for (uint32_t i = 0; i < units; ++i) checkpoint.merged.push_back(body[offset + i] != 0);
    offset += units;
    const uint64_t compressedSize = take<uint64_t>(body, offset);
    if (offset + compressedSize != body.size()) fail("%s: checkpoint is truncated", path);
    checkpoint.film = FilmBlock(0, 0, width, height, halves, smallerRadius);
    farm::decompressFilm(body.substr(offset), checkpoint.film);
    checkpoint.film.invalidSamples = invalid;
    return checkpoint;
}

}  // namespace alphorn::coordinator
