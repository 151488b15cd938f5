// The daemons' one HTTP server (Boost.Beast over Boost.Asio): /metrics, and the coordinator's
// web dashboard and its API. Off unless a daemon is given --http-listen. It speaks TLS with the
// daemon's certificate when it has one, and each route names the bearer tokens it accepts
// (`Authorization: Bearer <token>`), or is explicitly open to anyone.
//
// A request that no route's token authorizes is answered 401 before routing, whatever its path,
// so nobody learns which paths exist without a token; a request with a token the server knows
// gets 404 for an unknown path and 403 for a route that token does not open.
//
// No client can hold the server by being slow: connections are served asynchronously (a slow
// one holds no thread), each request must arrive whole (TLS handshake, head and body) within a
// total deadline, an idle kept-alive connection is closed, a response that is not read in time
// is dropped, and the connections open at once are capped, in all and per client address.
// Handlers run on the server's threads, one request at a time per thread.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace alphorn::farm {

struct HttpServerOptions {
    std::string listen = {};  // HOST:PORT ([IPV6]:PORT); port 0 picks a free one
    // PEM certificate chain and private key: serve HTTPS only. Both or neither.
    std::string tlsCertPath = {}, tlsKeyPath = {};
    // Threads that serve the connections and run the handlers.
    int threads = 4;
    // A request must arrive whole within this time: from the connection's acceptance (TLS
    // handshake included) for its first request, from its first byte for a later one. However
    // slowly a client sends, it holds a connection no longer than this.
    double requestSeconds = 10;
    // How long a kept-alive connection may wait for its next request.
    double idleSeconds = 5;
    // How long the client has to take a whole response.
    double responseSeconds = 60;
    // Connections open at once, in all and from one client address; beyond either, a new
    // connection is closed at once, without an answer.
    int maxConnections = 256;
    int maxConnectionsPerAddress = 32;
};

// Header names compare without regard to case, as HTTP has them.
struct HeaderNameLess {
    bool operator()(const std::string& a, const std::string& b) const;
};

struct HttpRequest {
    std::string method;  // "GET", "POST", ...
    std::string target;  // as sent: the path and the query ("/api/job?id=3")
    std::string path;    // the target's path, percent-decoded
    std::multimap<std::string, std::string, HeaderNameLess> headers;
    // The query's parameters, and those of a form body (application/x-www-form-urlencoded).
    std::multimap<std::string, std::string> params;
    std::string body;
    std::string remoteAddress;
    int remotePort = 0;

    // The first value of a header or parameter; empty when there is none.
    std::string header(const std::string& name) const;
    std::string param(const std::string& name) const;
    bool hasParam(const std::string& name) const { return params.count(name) > 0; }
};

struct HttpResponse {
    int status = 200;
    std::vector<std::pair<std::string, std::string>> headers;  // in order; a name may repeat
    std::string body;

    void addHeader(const std::string& name, const std::string& value) {
        headers.emplace_back(name, value);
    }
    // The body and its Content-Type.
    void setContent(std::string content, const std::string& contentType);
    void redirect(const std::string& location, int redirectStatus);
};

// Who may use a route.
struct RouteAccess {
    std::vector<std::string> tokens;  // any of these bearer tokens (compared in constant time)
    bool anonymous = false;           // anyone, without a token: only when explicitly configured
};

class HttpServer {
  public:
    using Handler = std::function<void(const HttpRequest&, HttpResponse&)>;

    // Loads the certificate (throws Error naming the file when it cannot); does not listen yet.
    explicit HttpServer(HttpServerOptions options);
    ~HttpServer();
    HttpServer(const HttpServer&) = delete;
    HttpServer& operator=(const HttpServer&) = delete;

    // Routes are added before start(). `path` is matched exactly, and one access applies to all
    // methods of a path. Throws Error for a route that is neither anonymous nor given a token.
    // A GET route answers HEAD as well.
    void get(const std::string& path, RouteAccess access, Handler handler);
    void post(const std::string& path, RouteAccess access, Handler handler);

    // Binds the address (throws Error "cannot listen on ..." when it is taken or invalid) and
    // serves on threads of its own until stop().
    void start();
    void stop();
    int port() const { return m_port; }
    bool tls() const { return !m_options.tlsCertPath.empty(); }

    struct Transport;  // Asio's objects and the connections' limits, in http_server.cpp
    // The answer to one request: access rules, routing, a handler's exceptions. Public for the
    // connections, which live in http_server.cpp.
    HttpResponse answer(const HttpRequest& request) const;

  private:
    struct Route {
        RouteAccess access;
        std::map<std::string, Handler> handlers;  // by method
    };
    void addRoute(const std::string& method, const std::string& path, RouteAccess access,
                  Handler handler);

    HttpServerOptions m_options;
    std::map<std::string, Route> m_routes;  // by path
    std::vector<std::string> m_allTokens;   // of every route
    std::unique_ptr<Transport> m_transport;
    int m_port = 0;
};

// HOST and PORT of "HOST:PORT" or "[IPV6]:PORT"; throws Error on anything else.
std::pair<std::string, int> splitHostPort(const std::string& address);

}  // namespace alphorn::farm
