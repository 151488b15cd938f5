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

// `owner` names the job the checkpoint belongs to (JobFilm's owner: the job's id in this state
// directory); a checkpoint is read back only by its owner, so a file that ended up in another
// job's directory cannot give that job its image.
void writeCheckpoint(const std::string& path, const std::string& owner, const FilmBlock& film,
                     const std::vector<bool>& merged);
// Throws Error when the file is corrupt, belongs to another owner or does not match the expected
// shape. Checkpoints of versions 1 to 3 (before owners) are read as belonging to any.
Checkpoint readCheckpoint(const std::string& path, const std::string& owner, int width, int height,
                          uint32_t unitCount);

}  // namespace alphorn::coordinator
