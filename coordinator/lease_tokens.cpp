#include "coordinator/lease_tokens.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>

#include <cstring>

namespace alphorn::coordinator {

std::string LeaseTokens::tokenOfEpoch(uint64_t epoch, uint64_t leaseId, uint64_t workerId,
                                      uint64_t jobId, uint32_t unitIndex) const {
    uint64_t fields[5] = {epoch, leaseId, workerId, jobId, unitIndex};
    unsigned char mac[EVP_MAX_MD_SIZE];
    unsigned int macSize = 0;
    HMAC(EVP_sha256(), m_key.data(), int(m_key.size()),
         reinterpret_cast<const unsigned char*>(fields), sizeof fields, mac, &macSize);
    std::string token(reinterpret_cast<const char*>(&epoch), sizeof epoch);
    token.append(reinterpret_cast<const char*>(mac), macSize);
    return token;
}

double LeaseTokens::auditDraw(uint64_t jobId, uint32_t unitIndex) const {
    // Epoch 0 is no process's (epochs count from 1) and no lease has the largest id: the draw
    // is never some lease's token.
    const std::string mac = tokenOfEpoch(0, UINT64_MAX, 0, jobId, unitIndex);
    uint64_t bits = 0;
    std::memcpy(&bits, mac.data() + sizeof(uint64_t), sizeof bits);
    return double(bits >> 11) * 0x1p-53;
}

bool LeaseTokens::grantedEarlier(const std::string& token, uint64_t leaseId, uint64_t workerId,
                                 uint64_t jobId, uint32_t unitIndex) const {
    uint64_t epoch = 0;
    if (token.size() < sizeof epoch) return false;
    std::memcpy(&epoch, token.data(), sizeof epoch);
    if (epoch >= m_epoch) return false;
    const std::string expected = tokenOfEpoch(epoch, leaseId, workerId, jobId, unitIndex);
    return token.size() == expected.size() &&
           CRYPTO_memcmp(token.data(), expected.data(), token.size()) == 0;
}

}  // namespace alphorn::coordinator
