#include "coordinator/dashboard_sessions.h"

#include "common/core/error.h"
#include "common/farm/rpc.h"
#include "common/farm/sha256.h"

#include <openssl/crypto.h>

#include <algorithm>

namespace alphorn::coordinator {

namespace {

bool sameToken(std::string_view given, const std::string& expected) {
    return !expected.empty() && given.size() == expected.size() &&
           CRYPTO_memcmp(given.data(), expected.data(), expected.size()) == 0;
}

}  // namespace

DashboardSessions::DashboardSessions(std::string operatorToken, std::string viewerToken)
    : m_operatorToken(std::move(operatorToken)), m_viewerToken(std::move(viewerToken)) {
    if (m_operatorToken.empty()) fail("the dashboard needs the client token");
    if (m_viewerToken == m_operatorToken)
        fail("the dashboard viewer token must differ from the client token");
}

DashboardRole DashboardSessions::roleOfToken(std::string_view token) const {
    const bool operatorToken = sameToken(token, m_operatorToken);
    const bool viewerToken = sameToken(token, m_viewerToken);
    if (operatorToken) return DashboardRole::Operator;
    return viewerToken ? DashboardRole::Viewer : DashboardRole::None;
}

std::string DashboardSessions::open(DashboardRole role, double now) {
    if (role == DashboardRole::None) fail("a dashboard session needs a role");
    std::string id = farm::generateToken();
    std::lock_guard lock(m_mutex);
    for (auto it = m_sessions.begin(); it != m_sessions.end();)
        it = it->second.expiresAt <= now ? m_sessions.erase(it) : std::next(it);
    if (m_sessions.size() >= kMaxSessions)
        m_sessions.erase(std::min_element(
            m_sessions.begin(), m_sessions.end(),
            [](const auto& a, const auto& b) { return a.second.expiresAt < b.second.expiresAt; }));
    m_sessions[farm::sha256Hex(id)] = Session{role, now + kLifetimeSeconds};
    return id;
}

DashboardRole DashboardSessions::roleOfSession(std::string_view id, double now) {
    if (id.empty()) return DashboardRole::None;
    std::lock_guard lock(m_mutex);
    auto it = m_sessions.find(farm::sha256Hex(id));
    if (it == m_sessions.end()) return DashboardRole::None;
    if (it->second.expiresAt <= now) {
        m_sessions.erase(it);
        return DashboardRole::None;
    }
    return it->second.role;
}

void DashboardSessions::close(std::string_view id) {
    std::lock_guard lock(m_mutex);
    m_sessions.erase(farm::sha256Hex(id));
}

size_t DashboardSessions::size() const {
    std::lock_guard lock(m_mutex);
    return m_sessions.size();
}

}  // namespace alphorn::coordinator
