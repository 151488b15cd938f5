#include "common/farm/chunks.h"

#include <algorithm>

namespace alphorn::farm {

bool sendChunks(std::string_view bytes, const ChunkSink& sink, size_t chunkBytes) {
    size_t offset = 0;
    do {
        const size_t n = std::min(chunkBytes, bytes.size() - offset);
        const bool first = offset == 0;
        offset += n;
        if (!sink(bytes.substr(offset - n, n), first, offset == bytes.size())) return false;
    } while (offset < bytes.size());
    return true;
}

bool sendChunks(std::istream& in, const ChunkSink& sink, size_t chunkBytes) {
    // One chunk read ahead, so that the one before the end is known to be the last.
    std::string current(chunkBytes, '\0'), next(chunkBytes, '\0');
    in.read(current.data(), static_cast<std::streamsize>(chunkBytes));
    current.resize(static_cast<size_t>(in.gcount()));
    bool first = true;
    for (;;) {
        size_t nextSize = 0;
        if (in) {
            next.resize(chunkBytes);
            in.read(next.data(), static_cast<std::streamsize>(chunkBytes));
            nextSize = static_cast<size_t>(in.gcount());
        }
        const bool last = nextSize == 0;
        if (!sink(current, first, last)) return false;
        if (last) return true;
        first = false;
        next.resize(nextSize);
        std::swap(current, next);
    }
}

}  // namespace alphorn::farm
