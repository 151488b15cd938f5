// A job's film checkpoint: the exact sums merged so far and which units they contain, in one
// file written atomically (temp file, fsync, rename). After a crash the coordinator reloads it
// and renders only the units it does not list, so at most one checkpoint interval is lost.
#pragma once

#include "common/render/film.h"

#include <string>
#include <vector>

namespace alphorn::coordinator {

struct Checkpoint {
    FilmBlock film;
    std::vector<bool> merged;  // per unit index
};

void writeCheckpoint(const std::string& path, const FilmBlock& film,
                     const std::vector<bool>& merged);
// Throws Error when the file is corrupt or does not match the expected shape.
Checkpoint readCheckpoint(const std::string& path, int width, int height, uint32_t unitCount);

}  // namespace alphorn::coordinator
