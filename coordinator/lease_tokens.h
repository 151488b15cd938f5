// Signed lease tokens. A worker shows the token of each lease it holds in its heartbeats; after a
// coordinator restart the new process re-adopts a unit only when the token proves that an earlier
// process (an earlier epoch of the state directory) granted exactly that lease to that worker.
#pragma once

#include <cstdint>
#include <string>

namespace alphorn::coordinator {

class LeaseTokens {
  public:
    // `key`: the HMAC key kept in the job store; `epoch`: this process's start number.
    LeaseTokens(std::string key, uint64_t epoch) : m_key(std::move(key)), m_epoch(epoch) {}

    uint64_t epoch() const { return m_epoch; }
    // The token of a lease granted by this process.
    std::string token(uint64_t leaseId, uint64_t workerId, uint64_t jobId,
                      uint32_t unitIndex) const {
        return tokenOfEpoch(m_epoch, leaseId, workerId, jobId, unitIndex);
    }
    // True when `token` was signed with this key by an earlier epoch for exactly this lease;
    // this process's own leases are never re-adopted (they are in its lease table or expired).
    bool grantedEarlier(const std::string& token, uint64_t leaseId, uint64_t workerId,
                        uint64_t jobId, uint32_t unitIndex) const;

    // A number in [0, 1) drawn from the unit's id with this key: whether the unit is audited
    // (LeaseScheduler). Secret like the tokens, so no worker can tell which units are.
    double auditDraw(uint64_t jobId, uint32_t unitIndex) const;

  private:
    std::string tokenOfEpoch(uint64_t epoch, uint64_t leaseId, uint64_t workerId, uint64_t jobId,
                             uint32_t unitIndex) const;

    std::string m_key;
    uint64_t m_epoch;
};

}  // namespace alphorn::coordinator
