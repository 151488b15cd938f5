#include "common/farm/sha256.h"

#include "common/core/error.h"

#include <openssl/evp.h>

#include <cstring>
#include <fstream>
#include <memory>

namespace alphorn::farm {

struct Sha256::State {
    EVP_MD_CTX* context = nullptr;
};

Sha256::Sha256() : m_state(std::make_unique<State>()) {
    m_state->context = EVP_MD_CTX_new();
    if (!m_state->context || EVP_DigestInit_ex(m_state->context, EVP_sha256(), nullptr) != 1)
        fail("cannot initialise SHA-256 (OpenSSL)");
}

Sha256::~Sha256() {
    EVP_MD_CTX_free(m_state->context);
}

void Sha256::update(std::string_view bytes) {
    if (EVP_DigestUpdate(m_state->context, bytes.data(), bytes.size()) != 1)
        fail("SHA-256 update failed (OpenSSL)");
}

std::string Sha256::finishHex() {
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int length = 0;
    if (EVP_DigestFinal_ex(m_state->context, digest, &length) != 1)
        fail("SHA-256 final failed (OpenSSL)");
    static const char* kHex = "0123456789abcdef";
    std::string hex;
    hex.reserve(2 * length);
    for (unsigned int i = 0; i < length; ++i) {
        hex.push_back(kHex[digest[i] >> 4]);
        hex.push_back(kHex[digest[i] & 15]);
    }
    return hex;
}

std::string sha256Hex(std::string_view bytes) {
    Sha256 hasher;
    hasher.update(bytes);
    return hasher.finishHex();
}

std::string sha256OfFile(const std::string& path) {
    std::ifstream file(path, std::ios::binary);
    if (!file) fail("%s: cannot open: %s", path, std::strerror(errno));
    Sha256 hasher;
    // Not zero-filled: a bundle of small files would otherwise pay for clearing 1 MiB per file.
    constexpr size_t kChunk = 1 << 20;
    const auto buffer = std::make_unique_for_overwrite<char[]>(kChunk);
    while (file) {
        file.read(buffer.get(), static_cast<std::streamsize>(kChunk));
        hasher.update(std::string_view(buffer.get(), static_cast<size_t>(file.gcount())));
    }
    if (file.bad()) fail("%s: read error", path);
    return hasher.finishHex();
}

bool isSha256Hex(std::string_view text) {
    if (text.size() != 64) return false;
    for (char c : text)
        if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
    return true;
}

}  // namespace alphorn::farm
