// Small file helpers the daemons share: whole-file reads and crash-safe writes.
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

}  // namespace alphorn::farm
