// SHA-256 (OpenSSL) as lowercase hex: the names of blobs in the content-addressed store.
#pragma once

#include <memory>
#include <string>
#include <string_view>

namespace alphorn::farm {

// Incremental hashing for streams (uploads, downloads) that never hold a whole file in memory.
class Sha256 {
  public:
    Sha256();
    ~Sha256();
    Sha256(const Sha256&) = delete;
    Sha256& operator=(const Sha256&) = delete;

    void update(std::string_view bytes);
    // Lowercase hex digest; the hasher cannot be updated afterwards.
    std::string finishHex();

  private:
    struct State;
    std::unique_ptr<State> m_state;
};

std::string sha256Hex(std::string_view bytes);
// Hash of a file's contents; throws Error naming the path when it cannot be read.
std::string sha256OfFile(const std::string& path);
// True for 64 lowercase hex digits (guards file names built from client-supplied hashes).
bool isSha256Hex(std::string_view text);

}  // namespace alphorn::farm
