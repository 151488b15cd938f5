// The daemons' one HTTP server (cpp-httplib from Debian): /metrics now, the coordinator's web
// dashboard later. Off unless a daemon is given --http-listen. It speaks TLS with the daemon's
// certificate when it has one, and every route needs an `Authorization: Bearer <token>` header
// with one of the tokens it is given, unless the route was registered as anonymous.
//
// A request without an accepted token is answered 401 before routing, whatever its path, so
// nobody learns which paths exist without a token; an authenticated request to an unknown path
// gets 404.
#pragma once

#include <httplib.h>

#include <atomic>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace alphorn::farm {

struct HttpServerOptions {
    std::string listen;  // HOST:PORT ([IPV6]:PORT); port 0 picks a free one
    // PEM certificate chain and private key: serve HTTPS only. Both or neither.
    std::string tlsCertPath, tlsKeyPath;
    // Accepted bearer tokens (compared in constant time); at least one unless every route is
    // anonymous.
    std::vector<std::string> tokens;
    // Request handler threads.
    int threads = 4;
};

class HttpServer {
  public:
    using Handler = std::function<void(const httplib::Request&, httplib::Response&)>;
    enum class Access { Token, Anonymous };

    // Loads the certificate (throws Error naming the file when it cannot); does not listen yet.
    explicit HttpServer(HttpServerOptions options);
    ~HttpServer();
    HttpServer(const HttpServer&) = delete;
    HttpServer& operator=(const HttpServer&) = delete;

    // Routes are added before start(). `path` is matched exactly.
    void get(const std::string& path, Access access, Handler handler);

    // Binds the address (throws Error "cannot listen on ..." when it is taken or invalid) and
    // serves on a thread of its own until stop().
    void start();
    void stop();
    int port() const { return m_port; }
    bool tls() const { return !m_options.tlsCertPath.empty(); }

    // Whether `request` carries one of the accepted tokens.
    bool authorized(const httplib::Request& request) const;

  private:
    HttpServerOptions m_options;
    std::unique_ptr<httplib::Server> m_server;
    std::set<std::string> m_anonymousPaths;
    std::thread m_thread;
    std::atomic<bool> m_listenEnded{false};
    int m_port = 0;
};

// HOST and PORT of "HOST:PORT" or "[IPV6]:PORT"; throws Error on anything else.
std::pair<std::string, int> splitHostPort(const std::string& address);

}  // namespace alphorn::farm
