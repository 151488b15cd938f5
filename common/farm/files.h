// Small file helpers the daemons share: whole-file reads, crash-safe writes and a check that a
// directory can be written.
#pragma once

#include <string>
#include <string_view>

namespace alphorn::farm {

std::string readFile(const std::string& path);
// Writes via a temporary file in the same directory, fsync, rename, fsync of the directory:
// after a crash the path holds either the old or the new contents, never a torn mix.
void writeFileAtomically(const std::string& path, std::string_view contents);
// Moves a finished file (already closed) to `path` with the same guarantee: its bytes are
// flushed to disk before the rename, and the rename itself before returning.
void publishFileAtomically(const std::string& temporary, const std::string& path);
// Why nothing can be written into `directory` (a small file written, flushed and removed: the
// disk is full, read-only or failing), or "" when it can. Tells a daemon's own storage failing
// from a problem of the job it was preparing.
std::string directoryWriteProblem(const std::string& directory);

}  // namespace alphorn::farm
