// Cutting bytes into the chunks every farm stream carries (results, blobs, images), in one place:
// each call site only says what goes into a chunk besides its data.
#pragma once

#include <cstddef>
#include <functional>
#include <istream>
#include <string>
#include <string_view>

namespace alphorn::farm {

// Called once per chunk, in order: its data (at most the chunk size), whether it is the stream's
// first and its last chunk. Returns false to stop (the peer went away).
using ChunkSink = std::function<bool(std::string_view data, bool first, bool last)>;

// Hands `bytes` to `sink` in chunks of at most `chunkBytes`. Empty bytes still make one (empty,
// first and last) chunk: a stream always carries its header. False when `sink` stopped.
bool sendChunks(std::string_view bytes, const ChunkSink& sink, size_t chunkBytes);
// The same for a stream read to its end; a read error ends it like its end would (the caller,
// which knows the expected size, checks). Marks the last chunk without reading past it twice.
bool sendChunks(std::istream& in, const ChunkSink& sink, size_t chunkBytes);

// Appends every chunk's data a gRPC reader yields to `bytes`; `onChunk`, when given, sees each
// chunk first (the header of the first one, say) and may refuse it by returning false, which
// stops reading. Returns false when refused.
template <typename Reader, typename Chunk>
bool receiveChunks(Reader& reader, std::string& bytes,
                   const std::function<bool(const Chunk&)>& onChunk = nullptr) {
    Chunk chunk;
    while (reader.Read(&chunk)) {
        if (onChunk && !onChunk(chunk)) return false;
        bytes += chunk.data();
    }
    return true;
}

}  // namespace alphorn::farm
