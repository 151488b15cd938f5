// The daemons' one HTTP server (cpp-httplib from Debian): /metrics, and the coordinator's web
// dashboard and its API. Off unless a daemon is given --http-listen. It speaks TLS with the
// daemon's certificate when it has one, and each route names the bearer tokens it accepts
// (`Authorization: Bearer <token>`), or is explicitly open to anyone.
//
// A request that no route's token authorizes is answered 401 before routing, whatever its path,
// so nobody learns which paths exist without a token; a request with a token the server knows
// gets 404 for an unknown path and 403 for a route that token does not open.
#pragma once

#include <httplib.h>
// <resolv.h>, which httplib.h includes, defines `_res` as a macro, and Eigen (among others) uses
// the name for parameters. Nothing here needs the resolver's state.
#undef _res

#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace alphorn::farm {

struct HttpServerOptions {
    std::string listen = {};  // HOST:PORT ([IPV6]:PORT); port 0 picks a free one
    // PEM certificate chain and private key: serve HTTPS only. Both or neither.
    std::string tlsCertPath = {}, tlsKeyPath = {};
    // Request handler threads.
    int threads = 4;
};

// Who may use a route.
struct RouteAccess {
    std::vector<std::string> tokens;  // any of these bearer tokens (compared in constant time)
    bool anonymous = false;           // anyone, without a token: only when explicitly configured
};

class HttpServer {
  public:
    using Handler = std::function<void(const httplib::Request&, httplib::Response&)>;

    // Loads the certificate (throws Error naming the file when it cannot); does not listen yet.
    explicit HttpServer(HttpServerOptions options);
    ~HttpServer();
    HttpServer(const HttpServer&) = delete;
    HttpServer& operator=(const HttpServer&) = delete;

    // Routes are added before start(). `path` is matched exactly, and one access applies to all
    // methods of a path. Throws Error for a route that is neither anonymous nor given a token.
    void get(const std::string& path, RouteAccess access, Handler handler);
    void post(const std::string& path, RouteAccess access, Handler handler);

    // Binds the address (throws Error "cannot listen on ..." when it is taken or invalid) and
    // serves on a thread of its own until stop().
    void start();
    void stop();
    int port() const { return m_port; }
    bool tls() const { return !m_options.tlsCertPath.empty(); }

  private:
    // Records who may use `path` and returns its pattern for httplib (a literal match).
    std::string addRoute(const std::string& path, RouteAccess access);

    HttpServerOptions m_options;
    std::unique_ptr<httplib::Server> m_server;
    std::map<std::string, RouteAccess> m_routes;  // by path
    std::vector<std::string> m_allTokens;         // of every route
    std::thread m_thread;
    std::atomic<bool> m_listenEnded{false};
    int m_port = 0;
};

// HOST and PORT of "HOST:PORT" or "[IPV6]:PORT"; throws Error on anything else.
std::pair<std::string, int> splitHostPort(const std::string& address);

}  // namespace alphorn::farm
