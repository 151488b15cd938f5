#include "common/farm/http_server.h"

#include "common/core/error.h"
#include "common/farm/log.h"

#include <openssl/crypto.h>
#include <openssl/err.h>
#include <openssl/ssl.h>
#include <sys/socket.h>

namespace alphorn::farm {

namespace {

std::string openSslError() {
    const unsigned long code = ERR_get_error();
    if (code == 0) return "unknown OpenSSL error";
    char text[256];
    ERR_error_string_n(code, text, sizeof text);
    ERR_clear_error();
    return text;
}

// Only SO_REUSEADDR (a restarted daemon binds again while old connections linger): httplib's
// default adds SO_REUSEPORT, which would let a second daemon listen on the same port and take
// part of the requests.
void socketOptions(socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
}

// Whether the request's bearer token is one of `tokens`. Every token is compared, in constant
// time, so the time taken tells nothing about which one matched or how much of it.
bool carriesOneOf(const httplib::Request& request, const std::vector<std::string>& tokens) {
    const std::string value = request.get_header_value("Authorization");
    const std::string_view prefix = "Bearer ";
    if (value.compare(0, prefix.size(), prefix) != 0) return false;
    const std::string_view token = std::string_view(value).substr(prefix.size());
    bool accepted = false;
    for (const std::string& expected : tokens)
        accepted |= token.size() == expected.size() &&
                    CRYPTO_memcmp(token.data(), expected.data(), expected.size()) == 0;
    return accepted;
}

void plainText(httplib::Response& response, int status, const std::string& text) {
    response.status = status;
    response.set_content(text + "\n", "text/plain; charset=utf-8");
}

}  // namespace

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

HttpServer::HttpServer(HttpServerOptions options) : m_options(std::move(options)) {
    splitHostPort(m_options.listen);  // a bad address is reported before anything else
    if (m_options.tlsCertPath.empty() != m_options.tlsKeyPath.empty())
        fail("the HTTP server needs both a TLS certificate and its key, or neither");
    if (m_options.tlsCertPath.empty()) {
        m_server = std::make_unique<httplib::Server>();
    } else {
        // The context is set up here rather than by httplib's path constructor, so that a
        // certificate that does not load is reported with OpenSSL's reason and old protocol
        // versions are refused.
        std::string problem;
        auto setup = [&](SSL_CTX& context) {
            if (SSL_CTX_set_min_proto_version(&context, TLS1_2_VERSION) != 1) {
                problem = "cannot require TLS 1.2: " + openSslError();
                return false;
            }
            if (SSL_CTX_use_certificate_chain_file(&context, m_options.tlsCertPath.c_str()) != 1) {
                problem = m_options.tlsCertPath +
                          ": cannot load the certificate chain: " + openSslError();
                return false;
            }
            if (SSL_CTX_use_PrivateKey_file(&context, m_options.tlsKeyPath.c_str(),
                                            SSL_FILETYPE_PEM) != 1) {
                problem = m_options.tlsKeyPath + ": cannot load the private key: " + openSslError();
                return false;
            }
            if (SSL_CTX_check_private_key(&context) != 1) {
                problem = m_options.tlsKeyPath + " is not the key of " + m_options.tlsCertPath;
                return false;
            }
            return true;
        };
        auto server = std::make_unique<httplib::SSLServer>(setup);
        if (!server->is_valid())
            fail("HTTP server: %s", problem.empty() ? openSslError() : problem);
        m_server = std::move(server);
    }
    const int threads = std::max(1, m_options.threads);
    m_server->new_task_queue = [threads] { return new httplib::ThreadPool(size_t(threads)); };
    m_server->set_socket_options(socketOptions);
    m_server->set_pre_routing_handler(
        [this](const httplib::Request& request, httplib::Response& response) {
            auto route = m_routes.find(request.path);
            if (route != m_routes.end() &&
                (route->second.anonymous || carriesOneOf(request, route->second.tokens)))
                return httplib::Server::HandlerResponse::Unhandled;
            const bool known = carriesOneOf(request, m_allTokens);
            if (known && route == m_routes.end())
                return httplib::Server::HandlerResponse::Unhandled;  // 404 from the error handler
            logWarning("http.refused", {field("path", request.path),
                                        field("peer", request.remote_addr + ":" +
                                                          std::to_string(request.remote_port))});
            if (known) {
                plainText(response, 403, "403 forbidden: this token does not open " + request.path);
            } else {
                response.set_header("WWW-Authenticate", "Bearer realm=\"alphorn\"");
                plainText(response, 401,
                          "401 unauthorized: send the header Authorization: Bearer <token>");
            }
            return httplib::Server::HandlerResponse::Handled;
        });
    m_server->set_error_handler([](const httplib::Request& request, httplib::Response& response) {
        // An unknown path; a handler's own 404 (e.g. "no job 7") keeps its text.
        if (response.status == 404 && response.body.empty())
            plainText(response, 404, "404 not found: " + request.path);
    });
    m_server->set_exception_handler(
        [](const httplib::Request& request, httplib::Response& response, std::exception_ptr error) {
            std::string what = "unknown exception";
            try {
                std::rethrow_exception(error);
            } catch (const std::exception& e) {
                what = e.what();
            } catch (...) {
            }
            logWarning("http.internal_error", {field("path", request.path), field("error", what)});
            plainText(response, 500, "500 internal error: " + what);
        });
}

HttpServer::~HttpServer() {
    stop();
}

std::string HttpServer::addRoute(const std::string& path, RouteAccess access) {
    if (!access.anonymous && access.tokens.empty())
        fail("HTTP route %s: no token may use it and it is not open to anyone", path);
    for (const std::string& token : access.tokens) {
        if (token.empty()) fail("HTTP route %s: an empty token", path);
        m_allTokens.push_back(token);
    }
    m_routes[path] = std::move(access);
    // httplib matches patterns as regular expressions; paths are matched literally.
    std::string pattern;
    for (char c : path) {
        if (std::string_view(".^$|()[]{}*+?\\").find(c) != std::string_view::npos) pattern += '\\';
        pattern += c;
    }
    return pattern;
}

void HttpServer::get(const std::string& path, RouteAccess access, Handler handler) {
    m_server->Get(addRoute(path, std::move(access)), std::move(handler));
}

void HttpServer::post(const std::string& path, RouteAccess access, Handler handler) {
    m_server->Post(addRoute(path, std::move(access)), std::move(handler));
}

void HttpServer::start() {
    const auto [host, port] = splitHostPort(m_options.listen);
    m_port = port == 0 ? m_server->bind_to_any_port(host)
                       : (m_server->bind_to_port(host, port) ? port : -1);
    if (m_port <= 0)
        fail("cannot listen on %s (HTTP): in use or not an address of this machine",
             m_options.listen);
    m_listenEnded = false;
    m_thread = std::thread([this] {
        m_server->listen_after_bind();
        m_listenEnded = true;
    });
    // httplib's stop() does nothing before the listening loop runs: wait for it, so that a
    // stop() right after start() cannot leave the thread serving forever.
    while (!m_server->is_running() && !m_listenEnded)
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

void HttpServer::stop() {
    if (!m_thread.joinable()) return;
    m_server->stop();
    m_thread.join();
}

}  // namespace alphorn::farm
