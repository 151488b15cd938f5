// Fuzzes the coordinator's checkpoint reader, readCheckpoint(), which a restarted coordinator
// runs on whatever a crash or a full disk left in its state directory. See fuzz_support.h for
// the input layout (the expected job shape, then the file).
#include "coordinator/checkpoint.h"
#include "common/core/error.h"
#include "common/farm/sha256.h"
#include "fuzz/fuzz_support.h"

#include <cstdio>
#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace alphorn;
    if (size < fuzz::kCheckpointHeaderBytes) return -1;
    const fuzz::CheckpointShape shape = fuzz::checkpointShapeFromHeader(data);
    std::string file(fuzz::asText(data, size).substr(fuzz::kCheckpointHeaderBytes));
    if (shape.appendChecksum) file += farm::sha256Hex(file);
    const std::string path = fuzz::scratchDirectory() + "/film.ckpt";
    fuzz::writeFile(path, file);
    try {
        coordinator::Checkpoint checkpoint = coordinator::readCheckpoint(
            path, fuzz::kCheckpointOwner, shape.width, shape.height, shape.units);
        if (checkpoint.merged.size() != shape.units || checkpoint.film.width() != shape.width ||
            checkpoint.film.height() != shape.height) {
            std::fprintf(stderr, "readCheckpoint accepted a checkpoint of the wrong shape\n");
            std::abort();
        }
        resolveImage(checkpoint.film, shape.width, shape.height);
    } catch (const Error&) {
    }
    return 0;
}
