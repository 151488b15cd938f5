// Who may use the web dashboard, and the login sessions of browsers. Two roles: an operator
// (the client token: sees everything and may act) and a viewer (the optional viewer token: sees
// everything, may not act). A browser logs in once with a token and then carries a session id in
// an HttpOnly cookie; the token itself never goes into the cookie, so a leaked cookie expires
// and a logout ends it. Sessions live in memory: a coordinator restart logs everybody out.
// Thread-safe.
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <string_view>

namespace alphorn::coordinator {

enum class DashboardRole { None, Viewer, Operator };

class DashboardSessions {
  public:
    static constexpr double kLifetimeSeconds = 12 * 3600.0;
    // At most this many sessions; a new one beyond it replaces the one closest to expiry.
    static constexpr size_t kMaxSessions = 1000;

    // `viewerToken` may be empty (no viewers). The tokens must differ.
    DashboardSessions(std::string operatorToken, std::string viewerToken);

    // The role a token gives. Both tokens are compared in constant time, so the time taken
    // tells nothing about which one matched or how much of it.
    DashboardRole roleOfToken(std::string_view token) const;
    // Opens a session for `role` at `now` (monotonic seconds) and returns its id, a random
    // 256-bit hex string for the cookie.
    std::string open(DashboardRole role, double now);
    // The role of a live session; None for an unknown, closed or expired id.
    DashboardRole roleOfSession(std::string_view id, double now);
    void close(std::string_view id);
    size_t size() const;

  private:
    struct Session {
        DashboardRole role = DashboardRole::None;
        double expiresAt = 0;
    };
    std::string m_operatorToken, m_viewerToken;
    mutable std::mutex m_mutex;
    // By the SHA-256 of the id: looking an id up then takes no time that depends on how much of
    // a stored id a guess matches.
    std::map<std::string, Session> m_sessions;
};

}  // namespace alphorn::coordinator
