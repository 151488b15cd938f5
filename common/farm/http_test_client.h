// A small blocking HTTP/1.1 client for the tests of the daemons' HTTP server (Boost.Beast): one
// connection per request, plain or TLS (verifying the server against a given certificate), with
// a deadline on the whole exchange.
#pragma once

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>

#include <strings.h>
#include <chrono>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace alphorn::farm {

using HttpHeaders = std::vector<std::pair<std::string, std::string>>;

struct HttpTestResponse {
    struct NameLess {
        bool operator()(const std::string& a, const std::string& b) const {
            return strcasecmp(a.c_str(), b.c_str()) < 0;
        }
    };
    int status = 0;
    std::multimap<std::string, std::string, NameLess> headers;
    std::string body;

    std::string header(const std::string& name) const {
        auto it = headers.find(name);
        return it == headers.end() ? std::string() : it->second;
    }
    bool hasHeader(const std::string& name) const { return headers.count(name) > 0; }
};

class HttpTestClient {
  public:
    // TLS when `caCertPath` is given: the server's certificate must be signed by it.
    HttpTestClient(std::string host, int port, std::string caCertPath = "")
        : m_host(std::move(host)), m_port(port), m_caCertPath(std::move(caCertPath)) {}

    void setTimeout(double seconds) { m_timeoutSeconds = seconds; }
    // Why the last request got no answer.
    const std::string& lastError() const { return m_lastError; }

    std::optional<HttpTestResponse> get(const std::string& target,
                                        const HttpHeaders& headers = {}) {
        return request(boost::beast::http::verb::get, target, headers, "", "");
    }
    std::optional<HttpTestResponse> post(const std::string& target, const HttpHeaders& headers,
                                         const std::string& body, const std::string& contentType) {
        return request(boost::beast::http::verb::post, target, headers, body, contentType);
    }
    // A form as a browser posts it (application/x-www-form-urlencoded).
    std::optional<HttpTestResponse> postForm(const std::string& target, const HttpHeaders& headers,
                                             const HttpHeaders& fields) {
        std::string body;
        for (const auto& [name, value] : fields)
            body += (body.empty() ? "" : "&") + formEncoded(name) + "=" + formEncoded(value);
        return post(target, headers, body, "application/x-www-form-urlencoded");
    }

  private:
    static std::string formEncoded(const std::string& text) {
        static const char* hex = "0123456789ABCDEF";
        std::string out;
        for (unsigned char c : text) {
            if (isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') {
                out += char(c);
            } else {
                out += '%';
                out += hex[c >> 4];
                out += hex[c & 15];
            }
        }
        return out;
    }

    std::optional<HttpTestResponse> request(boost::beast::http::verb method,
                                            const std::string& target, const HttpHeaders& headers,
                                            const std::string& body,
                                            const std::string& contentType) {
        namespace beast = boost::beast;
        namespace http = beast::http;
        http::request<http::string_body> message(method, target, 11);
        message.set(http::field::host, m_host + ":" + std::to_string(m_port));
        for (const auto& [name, value] : headers) message.insert(name, value);
        if (method == http::verb::post) {
            message.set(http::field::content_type, contentType);
            message.body() = body;
        }
        message.keep_alive(false);
        message.prepare_payload();
        http::response<http::string_body> answer;
        beast::error_code error;
        boost::asio::io_context io;
        if (m_caCertPath.empty()) {
            beast::tcp_stream stream(io);
            error = exchange(io, stream, message, answer);
        } else {
            boost::asio::ssl::context context(boost::asio::ssl::context::tls_client);
            context.load_verify_file(m_caCertPath, error);
            if (error) return failed(error);
            context.set_verify_mode(boost::asio::ssl::verify_peer);
            beast::ssl_stream<beast::tcp_stream> stream(io, context);
            error = exchange(io, stream, message, answer);
        }
        if (error) return failed(error);
        HttpTestResponse response;
        response.status = int(answer.result_int());
        for (const auto& header : answer)
            response.headers.emplace(std::string(header.name_string()),
                                     std::string(header.value()));
        response.body = std::move(answer.body());
        m_lastError.clear();
        return response;
    }

    std::optional<HttpTestResponse> failed(const boost::beast::error_code& error) {
        m_lastError = error.message();
        return std::nullopt;
    }

    // Connects, (shakes hands,) writes the request and reads the answer, all within the timeout.
    template <class Stream>
    boost::beast::error_code exchange(
        boost::asio::io_context& io, Stream& stream,
        boost::beast::http::request<boost::beast::http::string_body>& message,
        boost::beast::http::response<boost::beast::http::string_body>& answer) {
        namespace beast = boost::beast;
        namespace http = beast::http;
        constexpr bool tls = !std::is_same_v<Stream, beast::tcp_stream>;
        beast::error_code result;
        beast::flat_buffer buffer;
        beast::tcp_stream& lowest = beast::get_lowest_layer(stream);
        lowest.expires_after(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
            std::chrono::duration<double>(m_timeoutSeconds)));
        std::function<void(beast::error_code)> read = [&](beast::error_code error) {
            if (error) {
                result = error;
                return;
            }
            http::async_read(stream, buffer, answer,
                             [&](beast::error_code error, size_t) { result = error; });
        };
        std::function<void(beast::error_code)> write = [&](beast::error_code error) {
            if (error) {
                result = error;
                return;
            }
            http::async_write(stream, message,
                              [&](beast::error_code error, size_t) { read(error); });
        };
        const boost::asio::ip::tcp::endpoint endpoint(boost::asio::ip::make_address(m_host),
                                                      m_port);
        lowest.async_connect(endpoint, [&](beast::error_code error) {
            if constexpr (tls) {
                if (error) return write(error);
                stream.async_handshake(boost::asio::ssl::stream_base::client, write);
            } else {
                write(error);
            }
        });
        io.run();
        return result;
    }

    std::string m_host;
    int m_port;
    std::string m_caCertPath;
    double m_timeoutSeconds = 10;
    std::string m_lastError;
};

}  // namespace alphorn::farm
