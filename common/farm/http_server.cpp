#include "common/farm/http_server.h"

#include "common/core/error.h"
#include "common/farm/log.h"

#include <openssl/crypto.h>
#include <openssl/err.h>
#include <openssl/ssl.h>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>

#include <strings.h>
#include <chrono>
#include <mutex>
#include <optional>
#include <thread>
#include <unordered_map>

namespace alphorn::farm {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;

namespace {

// A request's head (request line and headers) and body may be no larger than this: the
// dashboard's and the metrics' requests are small, and memory is not the client's to claim.
constexpr uint32_t kHeadLimit = 32 * 1024;
constexpr uint64_t kBodyLimit = 1024 * 1024;
// How long a closing TLS connection waits for the client's close_notify.
constexpr auto kTlsShutdownTime = std::chrono::seconds(2);

std::string openSslError() {
    const unsigned long code = ERR_get_error();
    if (code == 0) return "unknown OpenSSL error";
    char text[256];
    ERR_error_string_n(code, text, sizeof text);
    ERR_clear_error();
    return text;
}

Clock::duration durationOf(double seconds) {
    return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

// Whether the request's bearer token is one of `tokens`. Every token is compared, in constant
// time, so the time taken tells nothing about which one matched or how much of it.
bool carriesOneOf(const HttpRequest& request, const std::vector<std::string>& tokens) {
    const std::string value = request.header("Authorization");
    const std::string_view prefix = "Bearer ";
    if (value.compare(0, prefix.size(), prefix) != 0) return false;
    const std::string_view token = std::string_view(value).substr(prefix.size());
    bool accepted = false;
    for (const std::string& expected : tokens)
        accepted |= token.size() == expected.size() &&
                    CRYPTO_memcmp(token.data(), expected.data(), expected.size()) == 0;
    return accepted;
}

void plainText(HttpResponse& response, int status, const std::string& text) {
    response.status = status;
    response.setContent(text + "\n", "text/plain; charset=utf-8");
}

int hexDigit(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

// %XX escapes decoded; in a query or form, '+' is a space too.
std::string percentDecoded(std::string_view text, bool plusIsSpace) {
    std::string out;
    out.reserve(text.size());
    for (size_t i = 0; i < text.size(); ++i) {
        if (text[i] == '%' && i + 2 < text.size() && hexDigit(text[i + 1]) >= 0 &&
            hexDigit(text[i + 2]) >= 0) {
            out += char(hexDigit(text[i + 1]) * 16 + hexDigit(text[i + 2]));
            i += 2;
        } else {
            out += plusIsSpace && text[i] == '+' ? ' ' : text[i];
        }
    }
    return out;
}

// The parameters of "a=1&b=two" into `params`.
void addParams(std::string_view encoded, std::multimap<std::string, std::string>& params) {
    while (!encoded.empty()) {
        const size_t end = std::min(encoded.find('&'), encoded.size());
        const std::string_view pair = encoded.substr(0, end);
        encoded = end < encoded.size() ? encoded.substr(end + 1) : std::string_view();
        if (pair.empty()) continue;
        const size_t equals = std::min(pair.find('='), pair.size());
        params.emplace(percentDecoded(pair.substr(0, equals), true),
                       equals < pair.size() ? percentDecoded(pair.substr(equals + 1), true) : "");
    }
}

// A warning that may come in floods (a client opening hundreds of connections): logged at most
// every ten seconds, naming the latest peer and counting the events since the previous line.
// flush() logs the events that came after the latest line, once their ten seconds are over.
class OccasionalWarning {
  public:
    explicit OccasionalWarning(std::string event) : m_event(std::move(event)) {}
    void note(const std::string& peer, const std::string& reason) {
        std::unique_lock lock(m_mutex);
        ++m_count;
        m_peer = peer;
        m_reason = reason;
        logIfDue(lock);
    }
    void flush() {
        std::unique_lock lock(m_mutex);
        if (m_count > 0) logIfDue(lock);
    }

  private:
    void logIfDue(std::unique_lock<std::mutex>& lock) {
        const Clock::time_point now = Clock::now();
        if (m_logged && now - *m_logged < std::chrono::seconds(10)) return;
        m_logged = now;
        const int64_t count = std::exchange(m_count, 0);
        const std::string peer = m_peer, reason = m_reason;
        lock.unlock();
        if (peer.empty())
            logWarning(m_event, {field("reason", reason), field("count_since_last_line", count)});
        else
            logWarning(m_event, {field("peer", peer), field("reason", reason),
                                 field("count_since_last_line", count)});
    }

    const std::string m_event;
    std::mutex m_mutex;
    std::optional<Clock::time_point> m_logged;
    int64_t m_count = 0;
    std::string m_peer, m_reason;
};

// The connections open at once, in all and by client address.
class ConnectionCount {
  public:
    ConnectionCount(int maxTotal, int maxPerAddress)
        : m_maxTotal(std::max(1, maxTotal)), m_maxPerAddress(std::max(1, maxPerAddress)) {}

    // Whether one more connection from `address` may open; counted when it may.
    bool admit(const std::string& address) {
        const char* reason = nullptr;
        {
            std::lock_guard lock(m_mutex);
            int& fromAddress = m_byAddress[address];
            if (m_total >= m_maxTotal) {
                reason = "too many connections";
            } else if (fromAddress >= m_maxPerAddress) {
                reason = "too many connections from this address";
            } else {
                ++m_total;
                ++fromAddress;
                return true;
            }
            if (fromAddress == 0) m_byAddress.erase(address);
        }
        m_refusals.note(address, reason);
        return false;
    }
    void flushWarnings() { m_refusals.flush(); }
    void release(const std::string& address) {
        std::lock_guard lock(m_mutex);
        --m_total;
        auto it = m_byAddress.find(address);
        if (--it->second == 0) m_byAddress.erase(it);
    }

  private:
    const int m_maxTotal, m_maxPerAddress;
    std::mutex m_mutex;
    int m_total = 0;
    std::unordered_map<std::string, int> m_byAddress;
    OccasionalWarning m_refusals{"http.connection_refused"};
};

// One admitted connection's place in the count, given back when it closes.
class Admission {
  public:
    Admission(ConnectionCount& count, std::string address)
        : m_count(count), m_address(std::move(address)) {}
    ~Admission() { m_count.release(m_address); }
    Admission(const Admission&) = delete;
    Admission& operator=(const Admission&) = delete;
    const std::string& address() const { return m_address; }

  private:
    ConnectionCount& m_count;
    const std::string m_address;
};

struct Deadlines {
    Clock::duration request, idle, response;
};

}  // namespace

struct HttpServer::Transport {
    std::optional<asio::ssl::context> tls;
    std::optional<ConnectionCount> connections;
    OccasionalWarning tooSlow{"http.too_slow"};
    OccasionalWarning acceptFailures{"http.accept_failed"};
    Deadlines deadlines;
    // Live between start() and stop(); declared last, so that the connections its handlers own
    // are gone before the objects above.
    std::unique_ptr<asio::io_context> io;
    std::unique_ptr<tcp::acceptor> acceptor;
    std::unique_ptr<asio::steady_timer> warningFlush;
    std::vector<std::thread> threads;
};

namespace {

// One client connection, plain (beast::tcp_stream) or TLS (beast::ssl_stream over one). It
// owns itself through the handlers of its pending operation; when none is left, it closes.
// Every operation runs under a deadline of the stream's timer, which closes the socket when it
// passes, so a client that stops sending or reading is dropped without holding a thread.
template <class Stream>
class Connection : public std::enable_shared_from_this<Connection<Stream>> {
    static constexpr bool kTls = !std::is_same_v<Stream, beast::tcp_stream>;

  public:
    Connection(Stream stream, std::unique_ptr<Admission> admission, int port,
               HttpServer::Transport& transport, const HttpServer& server)
        : m_stream(std::move(stream)),
          m_admission(std::move(admission)),
          m_port(port),
          m_transport(transport),
          m_server(server) {}

    void start() {
        // The first request's deadline counts from here: the handshake is part of it.
        lowest().expires_after(m_transport.deadlines.request);
        if constexpr (kTls) {
            m_stream.async_handshake(asio::ssl::stream_base::server,
                                     [self = this->shared_from_this()](beast::error_code error) {
                                         if (error) return self->dropped(error, "handshake");
                                         self->readRequest();
                                     });
        } else {
            readRequest();
        }
    }

  private:
    beast::tcp_stream& lowest() { return beast::get_lowest_layer(m_stream); }

    void readRequest() {
        m_parser.emplace();
        m_parser->header_limit(kHeadLimit);
        m_parser->body_limit(kBodyLimit);
        http::async_read(m_stream, m_buffer, *m_parser,
                         [self = this->shared_from_this()](beast::error_code error, size_t) {
                             self->onRequest(error);
                         });
    }

    void onRequest(beast::error_code error) {
        if (error == http::error::header_limit)
            return refuse(431, "431 request header fields too large");
        if (error == http::error::body_limit) return refuse(413, "413 request body too large");
        if (error &&
            error.category() == http::make_error_code(http::error::bad_method).category() &&
            error != http::error::end_of_stream && error != http::error::partial_message)
            return refuse(400, "400 bad request: " + error.message());
        if (error) return dropped(error, "request");

        http::request<http::string_body>& message = m_parser->get();
        HttpRequest request;
        request.method = std::string(message.method_string());
        // HEAD is answered as GET without the body.
        const bool headOnly = request.method == "HEAD";
        if (headOnly) request.method = "GET";
        request.target = std::string(message.target());
        const size_t query = std::min(request.target.find('?'), request.target.size());
        request.path = percentDecoded(std::string_view(request.target).substr(0, query), false);
        if (query < request.target.size())
            addParams(std::string_view(request.target).substr(query + 1), request.params);
        for (const auto& header : message)
            request.headers.emplace(std::string(header.name_string()), std::string(header.value()));
        request.body = std::move(message.body());
        if (request.header("Content-Type").starts_with("application/x-www-form-urlencoded"))
            addParams(request.body, request.params);
        request.remoteAddress = m_admission->address();
        request.remotePort = m_port;
        send(m_server.answer(request), message.keep_alive(), headOnly);
    }

    // A request that cannot be read: answered, and the connection closed.
    void refuse(int status, const std::string& text) {
        HttpResponse response;
        plainText(response, status, text);
        send(std::move(response), false, false);
    }

    void send(HttpResponse response, bool keepAlive, bool headOnly) {
        m_response.emplace();
        http::response<http::string_body>& message = *m_response;
        message.version(11);
        message.result(unsigned(response.status));
        for (const auto& [name, value] : response.headers) message.insert(name, value);
        message.body() = std::move(response.body);
        message.keep_alive(keepAlive);
        message.prepare_payload();
        if (headOnly) message.body().clear();  // Content-Length stays that of the GET
        lowest().expires_after(m_transport.deadlines.response);
        http::async_write(
            m_stream, message,
            [self = this->shared_from_this(), keepAlive](beast::error_code error, size_t) {
                if (error) return self->dropped(error, "response");
                self->m_response.reset();
                if (keepAlive)
                    self->awaitNextRequest();
                else
                    self->close();
            });
    }

    // Between requests, the idle deadline; from the next request's first byte, its own.
    void awaitNextRequest() {
        if (m_buffer.size() > 0) {  // already here (pipelined)
            lowest().expires_after(m_transport.deadlines.request);
            return readRequest();
        }
        lowest().expires_after(m_transport.deadlines.idle);
        m_stream.async_read_some(m_buffer.prepare(4096), [self = this->shared_from_this()](
                                                             beast::error_code error, size_t size) {
            if (error) return;  // closed, or idle too long: nothing to report
            self->m_buffer.commit(size);
            self->lowest().expires_after(self->m_transport.deadlines.request);
            self->readRequest();
        });
    }

    void close() {
        if constexpr (kTls) {
            lowest().expires_after(kTlsShutdownTime);
            m_stream.async_shutdown([self = this->shared_from_this()](beast::error_code) {});
        } else {
            beast::error_code ignored;
            m_stream.socket().shutdown(tcp::socket::shutdown_send, ignored);
        }
    }

    // The connection ends without an answer: the client left, or was too slow.
    void dropped(beast::error_code error, const char* phase) {
        if (error == beast::error::timeout)
            m_transport.tooSlow.note(m_admission->address(),
                                     std::string("the ") + phase + " took too long");
    }

    Stream m_stream;
    std::unique_ptr<Admission> m_admission;
    const int m_port;
    HttpServer::Transport& m_transport;
    const HttpServer& m_server;
    beast::flat_buffer m_buffer;
    std::optional<http::request_parser<http::string_body>> m_parser;
    std::optional<http::response<http::string_body>> m_response;
};

void serve(HttpServer::Transport& transport, const HttpServer& server, tcp::socket socket) {
    beast::error_code error;
    const tcp::endpoint peer = socket.remote_endpoint(error);
    if (error) return;  // gone already
    asio::ip::address address = peer.address();
    if (address.is_v6() && address.to_v6().is_v4_mapped())
        address = asio::ip::make_address_v4(asio::ip::v4_mapped, address.to_v6());
    const std::string addressText = address.to_string();
    if (!transport.connections->admit(addressText)) return;  // the socket closes here
    auto admission = std::make_unique<Admission>(*transport.connections, addressText);
    if (transport.tls) {
        std::make_shared<Connection<beast::ssl_stream<beast::tcp_stream>>>(
            beast::ssl_stream<beast::tcp_stream>(std::move(socket), *transport.tls),
            std::move(admission), peer.port(), transport, server)
            ->start();
    } else {
        std::make_shared<Connection<beast::tcp_stream>>(beast::tcp_stream(std::move(socket)),
                                                        std::move(admission), peer.port(),
                                                        transport, server)
            ->start();
    }
}

void acceptNext(HttpServer::Transport& transport, const HttpServer& server) {
    transport.acceptor->async_accept(
        asio::make_strand(*transport.io),
        [&transport, &server](beast::error_code error, tcp::socket socket) {
            if (error == asio::error::operation_aborted) return;
            if (error) {
                // Out of file descriptors, most likely: try again shortly rather than spin.
                transport.acceptFailures.note("", error.message());
                auto pause = std::make_shared<asio::steady_timer>(*transport.io,
                                                                  std::chrono::milliseconds(100));
                pause->async_wait([&transport, &server, pause](beast::error_code) {
                    acceptNext(transport, server);
                });
                return;
            }
            serve(transport, server, std::move(socket));
            acceptNext(transport, server);
        });
}

// Every ten seconds, the occasional warnings' lines still owed.
void flushWarningsEvery10Seconds(HttpServer::Transport& transport) {
    transport.warningFlush->expires_after(std::chrono::seconds(10));
    transport.warningFlush->async_wait([&transport](beast::error_code error) {
        if (error) return;
        transport.connections->flushWarnings();
        transport.tooSlow.flush();
        transport.acceptFailures.flush();
        flushWarningsEvery10Seconds(transport);
    });
}

}  // namespace

bool HeaderNameLess::operator()(const std::string& a, const std::string& b) const {
    return strcasecmp(a.c_str(), b.c_str()) < 0;
}

std::string HttpRequest::header(const std::string& name) const {
    auto it = headers.find(name);
    return it == headers.end() ? std::string() : it->second;
}

std::string HttpRequest::param(const std::string& name) const {
    auto it = params.find(name);
    return it == params.end() ? std::string() : it->second;
}

void HttpResponse::setContent(std::string content, const std::string& contentType) {
    std::erase_if(headers, [](const auto& header) {
        return strcasecmp(header.first.c_str(), "Content-Type") == 0;
    });
    addHeader("Content-Type", contentType);
    body = std::move(content);
}

void HttpResponse::redirect(const std::string& location, int redirectStatus) {
    status = redirectStatus;
    addHeader("Location", location);
}

std::pair<std::string, int> splitHostPort(const std::string& address) {
    const size_t colon = address.rfind(':');
    if (colon == std::string::npos || colon == 0 || colon + 1 == address.size())
        fail("\"%s\" is not an address of the form HOST:PORT", address);
    std::string host = address.substr(0, colon);
    if (host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
    const std::string portText = address.substr(colon + 1);
    if (portText.find_first_not_of("0123456789") != std::string::npos || portText.size() > 5 ||
        std::stoi(portText) > 65535)
        fail("\"%s\": the port must be a number from 0 to 65535", address);
    return {host, std::stoi(portText)};
}

HttpServer::HttpServer(HttpServerOptions options)
    : m_options(std::move(options)), m_transport(std::make_unique<Transport>()) {
    splitHostPort(m_options.listen);  // a bad address is reported before anything else
    if (m_options.tlsCertPath.empty() != m_options.tlsKeyPath.empty())
        fail("the HTTP server needs both a TLS certificate and its key, or neither");
    m_transport->connections.emplace(m_options.maxConnections, m_options.maxConnectionsPerAddress);
    m_transport->deadlines = {durationOf(m_options.requestSeconds),
                              durationOf(m_options.idleSeconds),
                              durationOf(m_options.responseSeconds)};
    if (m_options.tlsCertPath.empty()) return;
    // Loaded here, so that a certificate that does not load stops the daemon at start with
    // OpenSSL's reason; old protocol versions are refused.
    ERR_clear_error();
    SSL_CTX* context = m_transport->tls.emplace(asio::ssl::context::tls_server).native_handle();
    if (SSL_CTX_set_min_proto_version(context, TLS1_2_VERSION) != 1)
        fail("HTTP server: cannot require TLS 1.2: %s", openSslError());
    if (SSL_CTX_use_certificate_chain_file(context, m_options.tlsCertPath.c_str()) != 1)
        fail("HTTP server: %s: cannot load the certificate chain: %s", m_options.tlsCertPath,
             openSslError());
    if (SSL_CTX_use_PrivateKey_file(context, m_options.tlsKeyPath.c_str(), SSL_FILETYPE_PEM) != 1)
        fail("HTTP server: %s: cannot load the private key: %s", m_options.tlsKeyPath,
             openSslError());
    if (SSL_CTX_check_private_key(context) != 1)
        fail("HTTP server: %s is not the key of %s (%s)", m_options.tlsKeyPath,
             m_options.tlsCertPath, openSslError());
}

HttpServer::~HttpServer() {
    stop();
}

void HttpServer::addRoute(const std::string& method, const std::string& path, RouteAccess access,
                          Handler handler) {
    if (!access.anonymous && access.tokens.empty())
        fail("HTTP route %s: no token may use it and it is not open to anyone", path);
    for (const std::string& token : access.tokens) {
        if (token.empty()) fail("HTTP route %s: an empty token", path);
        m_allTokens.push_back(token);
    }
    Route& route = m_routes[path];
    route.access = std::move(access);
    route.handlers[method] = std::move(handler);
}

void HttpServer::get(const std::string& path, RouteAccess access, Handler handler) {
    addRoute("GET", path, std::move(access), std::move(handler));
}

void HttpServer::post(const std::string& path, RouteAccess access, Handler handler) {
    addRoute("POST", path, std::move(access), std::move(handler));
}

HttpResponse HttpServer::answer(const HttpRequest& request) const {
    HttpResponse response;
    auto route = m_routes.find(request.path);
    if (route == m_routes.end() ||
        !(route->second.access.anonymous || carriesOneOf(request, route->second.access.tokens))) {
        const bool known = carriesOneOf(request, m_allTokens);
        if (known && route == m_routes.end()) {
            plainText(response, 404, "404 not found: " + request.path);
            return response;
        }
        logWarning("http.refused", {field("path", request.path),
                                    field("peer", request.remoteAddress + ":" +
                                                      std::to_string(request.remotePort))});
        if (known) {
            plainText(response, 403, "403 forbidden: this token does not open " + request.path);
        } else {
            response.addHeader("WWW-Authenticate", "Bearer realm=\"alphorn\"");
            plainText(response, 401,
                      "401 unauthorized: send the header Authorization: Bearer <token>");
        }
        return response;
    }
    auto handler = route->second.handlers.find(request.method);
    if (handler == route->second.handlers.end()) {
        std::string allowed;
        for (const auto& [method, unused] : route->second.handlers)
            allowed += (allowed.empty() ? "" : ", ") + method + (method == "GET" ? ", HEAD" : "");
        response.addHeader("Allow", allowed);
        plainText(response, 405, "405 method not allowed: " + request.path + " takes " + allowed);
        return response;
    }
    try {
        handler->second(request, response);
    } catch (...) {
        std::string what = "unknown exception";
        try {
            throw;
        } catch (const std::exception& e) {
            what = e.what();
        } catch (...) {
        }
        logWarning("http.internal_error", {field("path", request.path), field("error", what)});
        plainText(response, 500, "500 internal error: " + what);
    }
    // A handler's own 404 (e.g. "no job 7") keeps its text.
    if (response.status == 404 && response.body.empty())
        plainText(response, 404, "404 not found: " + request.path);
    return response;
}

void HttpServer::start() {
    Transport& transport = *m_transport;
    if (transport.io) return;
    const auto [host, port] = splitHostPort(m_options.listen);
    const int threads = std::max(1, m_options.threads);
    transport.io = std::make_unique<asio::io_context>(threads);
    transport.acceptor = std::make_unique<tcp::acceptor>(*transport.io);
    tcp::acceptor& acceptor = *transport.acceptor;
    beast::error_code error;
    tcp::resolver resolver(*transport.io);
    const auto endpoints = resolver.resolve(
        host, std::to_string(port), tcp::resolver::passive | tcp::resolver::numeric_service, error);
    bool listening = false;
    for (const auto& entry : endpoints) {
        error.clear();
        acceptor.open(entry.endpoint().protocol(), error);
        // Only SO_REUSEADDR (a restarted daemon binds again while old connections linger); never
        // SO_REUSEPORT, which would let a second daemon listen on the same port and take part of
        // the requests.
        if (!error) acceptor.set_option(tcp::acceptor::reuse_address(true), error);
        if (!error) acceptor.bind(entry.endpoint(), error);
        if (!error) acceptor.listen(asio::socket_base::max_listen_connections, error);
        if (!error) {
            listening = true;
            break;
        }
        beast::error_code ignored;
        acceptor.close(ignored);
    }
    if (!listening) {
        transport.acceptor.reset();
        transport.io.reset();
        fail("cannot listen on %s (HTTP): in use or not an address of this machine",
             m_options.listen);
    }
    m_port = acceptor.local_endpoint().port();
    acceptNext(transport, *this);
    transport.warningFlush = std::make_unique<asio::steady_timer>(*transport.io);
    flushWarningsEvery10Seconds(transport);
    for (int i = 0; i < threads; ++i)
        transport.threads.emplace_back([io = transport.io.get()] {
            for (;;) {
                try {
                    io->run();
                    return;
                } catch (const std::exception& e) {
                    logError("http.internal_error", {field("error", e.what())});
                }
            }
        });
}

void HttpServer::stop() {
    Transport& transport = *m_transport;
    if (!transport.io) return;
    transport.io->stop();
    for (std::thread& thread : transport.threads) thread.join();
    transport.threads.clear();
    transport.warningFlush.reset();
    transport.acceptor.reset();
    transport.io.reset();  // destroys the connections left
}

}  // namespace alphorn::farm
