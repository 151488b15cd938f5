#include "common/farm/rpc.h"

#include "common/core/error.h"
#include "common/core/warning.h"
#include "common/farm/files.h"

#include <absl/strings/ascii.h>
#include <absl/strings/str_format.h>
#include <fcntl.h>
#include <netdb.h>
#include <openssl/crypto.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/rand.h>
#include <openssl/ssl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <mutex>
#include <set>

namespace alphorn::farm {

std::string tokenPermissionWarning(const std::string& path, unsigned mode) {
    if ((mode & (S_IRGRP | S_IROTH)) == 0) return "";
    return absl::StrFormat(
        "the token file %s is readable by %s (mode %04o): whoever can read it can use "
        "the farm with this token; `chmod 600 %s` keeps it to its owner",
        path,
        (mode & S_IRGRP) && (mode & S_IROTH) ? "its group and others"
        : (mode & S_IRGRP)                   ? "its group"
                                             : "others",
        mode & 07777, path);
}

std::string readTokenFile(const std::string& path) {
    std::string text = readFile(path);
    struct stat info {};
    if (::stat(path.c_str(), &info) == 0) {
        const std::string warning = tokenPermissionWarning(path, info.st_mode);
        static std::mutex warnedMutex;
        static std::set<std::string> warned;
        std::lock_guard lock(warnedMutex);
        if (!warning.empty() && warned.insert(path).second) warn(warning);
    }
    std::string token(absl::StripAsciiWhitespace(text.substr(0, text.find('\n'))));
    if (token.size() < 16)
        fail(
            "%s: the token must be at least 16 characters (generate one with `openssl rand -hex "
            "32`)",
            path);
    return token;
}

std::string generateToken() {
    unsigned char bytes[32];
    if (RAND_bytes(bytes, sizeof bytes) != 1) fail("cannot generate a random token (OpenSSL)");
    static const char* kHex = "0123456789abcdef";
    std::string token;
    for (unsigned char b : bytes) {
        token.push_back(kHex[b >> 4]);
        token.push_back(kHex[b & 15]);
    }
    return token;
}

grpc::Status checkBearer(const grpc::ServerContext& context, const std::string& expected) {
    const auto& metadata = context.client_metadata();
    auto it = metadata.find("authorization");
    if (it == metadata.end())
        return grpc::Status(grpc::StatusCode::UNAUTHENTICATED, "missing bearer token");
    const std::string_view value(it->second.data(), it->second.size());
    const std::string_view prefix = "Bearer ";
    if (value.substr(0, prefix.size()) != prefix)
        return grpc::Status(grpc::StatusCode::UNAUTHENTICATED, "malformed authorization header");
    const std::string_view token = value.substr(prefix.size());
    if (token.size() != expected.size() ||
        CRYPTO_memcmp(token.data(), expected.data(), expected.size()) != 0)
        return grpc::Status(grpc::StatusCode::UNAUTHENTICATED, "wrong token for this service");
    return grpc::Status::OK;
}

void addBearer(grpc::ClientContext& context, const std::string& token) {
    context.AddMetadata("authorization", "Bearer " + token);
}

namespace {

// The X.509 certificates in PEM text, as OpenSSL reads them.
int countPemCertificates(const std::string& pem) {
    BIO* bio = BIO_new_mem_buf(pem.data(), static_cast<int>(pem.size()));
    if (!bio) return 0;
    int count = 0;
    while (X509* certificate = PEM_read_bio_X509(bio, nullptr, nullptr, nullptr)) {
        X509_free(certificate);
        ++count;
    }
    BIO_free(bio);
    ERR_clear_error();  // the read that ends the loop leaves an error queued
    return count;
}

// Refuses a certificate or key file gRPC cannot use, and a key that is not the certificate's:
// gRPC gave only "cannot listen on ADDRESS" for them, which blames the address.
void checkServerKeyPair(const std::string& certPath, const std::string& certPem,
                        const std::string& keyPath, const std::string& keyPem) {
    if (countPemCertificates(certPem) == 0)
        fail(
            "%s: holds no PEM certificate (--tls-cert names the coordinator's certificate "
            "chain, \"-----BEGIN CERTIFICATE-----\" ...)",
            certPath);
    BIO* keyBio = BIO_new_mem_buf(keyPem.data(), static_cast<int>(keyPem.size()));
    // No passphrase: OpenSSL's default callback would ask for one on the terminal.
    pem_password_cb* noPassphrase = [](char*, int, int, void*) { return 0; };
    EVP_PKEY* key =
        keyBio ? PEM_read_bio_PrivateKey(keyBio, nullptr, noPassphrase, nullptr) : nullptr;
    BIO_free(keyBio);
    BIO* certBio = BIO_new_mem_buf(certPem.data(), static_cast<int>(certPem.size()));
    X509* certificate = certBio ? PEM_read_bio_X509(certBio, nullptr, nullptr, nullptr) : nullptr;
    BIO_free(certBio);
    const bool matches = key && certificate && X509_check_private_key(certificate, key) == 1;
    X509_free(certificate);
    EVP_PKEY_free(key);
    ERR_clear_error();
    if (!key)
        fail(
            "%s: holds no unencrypted PEM private key (--tls-key names the key of --tls-cert, "
            "\"-----BEGIN PRIVATE KEY-----\" ...)",
            keyPath);
    if (!matches)
        fail(
            "%s: the private key does not belong to the first certificate of %s (--tls-key and "
            "--tls-cert must be a pair)",
            keyPath, certPath);
}

}  // namespace

std::shared_ptr<grpc::Channel> makeChannel(const std::string& address,
                                           const std::string& caCertPath) {
    grpc::ChannelArguments arguments;
    arguments.SetMaxReceiveMessageSize(kMaxMessageBytes);
    arguments.SetMaxSendMessageSize(kMaxMessageBytes);
    // Try again soon after a failed attempt, so a restarted coordinator is found within about a
    // second (gRPC's default backoff grows to two minutes).
    arguments.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 200);
    arguments.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 1000);
    // GRPC_ARG_MIN_RECONNECT_BACKOFF_MS is deliberately left at gRPC's default: despite its
    // name it is the time a connection attempt (TCP connect, TLS handshake, the server's HTTP/2
    // settings) may take before it is abandoned. At 200 ms, a coordinator answering a burst of
    // clients, or a TLS handshake that needed one more poll, failed every attempt.
    // Keepalive pings on open calls: a WatchJob stream to a coordinator whose machine vanished
    // (no reset ever arrives) fails within half a minute instead of hanging.
    arguments.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, 20000);
    arguments.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 10000);
    std::shared_ptr<grpc::ChannelCredentials> credentials;
    if (caCertPath.empty()) {
        credentials = grpc::InsecureChannelCredentials();
    } else {
        grpc::SslCredentialsOptions options;
        options.pem_root_certs = readFile(caCertPath);
        // gRPC takes a file that holds no certificate (a key, a wrong file) and fails every
        // connection attempt with a log line: a worker retried for ever, a client reported an
        // unreachable coordinator. Say what is wrong instead, before connecting.
        if (countPemCertificates(options.pem_root_certs) == 0)
            fail(
                "%s: holds no PEM certificate (--tls-ca names the CA certificate that signed the "
                "coordinator's, \"-----BEGIN CERTIFICATE-----\" ...)",
                caCertPath);
        credentials = grpc::SslCredentials(options);
    }
    return grpc::CreateCustomChannel(address, credentials, arguments);
}

void configureServer(grpc::ServerBuilder& builder) {
    builder.SetMaxReceiveMessageSize(kMaxMessageBytes);
    builder.SetMaxSendMessageSize(kMaxMessageBytes);
    // Accept the clients' keepalive pings (every 20 s, see makeChannel); by default a server
    // treats pings more often than every 5 minutes as abuse and closes the connection.
    builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS, 10000);
    builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
    // A connection that never completes its handshake, or carries no call for a minute, is
    // closed: silent connections must not pile up to the process's file limit, where gRPC's
    // listener stops accepting for good (clients reconnect on their next call).
    builder.AddChannelArgument(GRPC_ARG_SERVER_HANDSHAKE_TIMEOUT_MS, 10000);
    builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_IDLE_MS, 60000);
}

namespace {

// host and port of "host:port", "[v6]:port" or gRPC's "dns:///host:port".
bool splitAddress(std::string address, std::string& host, std::string& port) {
    for (const std::string scheme : {"dns:///", "ipv4:", "ipv6:"})
        if (address.rfind(scheme, 0) == 0) address = address.substr(scheme.size());
    if (!address.empty() && address[0] == '[') {
        const size_t close = address.find(']');
        if (close == std::string::npos || address.substr(close + 1, 1) != ":") return false;
        host = address.substr(1, close - 1);
        port = address.substr(close + 2);
    } else {
        const size_t colon = address.rfind(':');
        if (colon == std::string::npos) return false;
        host = address.substr(0, colon);
        port = address.substr(colon + 1);
    }
    return !host.empty() && !port.empty();
}

class Socket {
  public:
    explicit Socket(int fd = -1) : m_fd(fd) {}
    Socket(const Socket&) = delete;
    Socket& operator=(const Socket&) = delete;
    ~Socket() {
        if (m_fd >= 0) ::close(m_fd);
    }
    int fd() const { return m_fd; }

  private:
    int m_fd;
};

// A blocking TCP socket connected to `address` within `timeout` whose reads and writes time out
// after `timeout`, or nullptr.
std::unique_ptr<Socket> connectTo(const std::string& address, std::chrono::milliseconds timeout) {
    std::string host, port;
    if (!splitAddress(address, host, port)) return nullptr;
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* found = nullptr;
    if (::getaddrinfo(host.c_str(), port.c_str(), &hints, &found) != 0) return nullptr;
    std::unique_ptr<addrinfo, decltype(&::freeaddrinfo)> addresses(found, &::freeaddrinfo);
    for (const addrinfo* candidate = found; candidate; candidate = candidate->ai_next) {
        auto socket = std::make_unique<Socket>(::socket(
            candidate->ai_family, candidate->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
        if (socket->fd() < 0) continue;
        if (::connect(socket->fd(), candidate->ai_addr, candidate->ai_addrlen) != 0) {
            if (errno != EINPROGRESS) continue;
            pollfd writable{socket->fd(), POLLOUT, 0};
            if (::poll(&writable, 1, int(timeout.count())) != 1) continue;
            int error = 0;
            socklen_t size = sizeof error;
            if (::getsockopt(socket->fd(), SOL_SOCKET, SO_ERROR, &error, &size) != 0 || error != 0)
                continue;
        }
        ::fcntl(socket->fd(), F_SETFL, ::fcntl(socket->fd(), F_GETFL) & ~O_NONBLOCK);
        timeval limit{long(timeout.count() / 1000), long(timeout.count() % 1000) * 1000};
        ::setsockopt(socket->fd(), SOL_SOCKET, SO_RCVTIMEO, &limit, sizeof limit);
        ::setsockopt(socket->fd(), SOL_SOCKET, SO_SNDTIMEO, &limit, sizeof limit);
        return socket;
    }
    return nullptr;
}

// A plaintext gRPC server sends its HTTP/2 SETTINGS frame as soon as a connection opens, before
// the client says anything; a TLS server stays silent until the client's hello.
bool sendsHttp2Settings(const Socket& socket, std::chrono::milliseconds timeout) {
    pollfd readable{socket.fd(), POLLIN, 0};
    if (::poll(&readable, 1, int(timeout.count())) != 1) return false;
    unsigned char header[9];
    size_t received = 0;
    while (received < sizeof header) {
        const ssize_t n = ::recv(socket.fd(), header + received, sizeof header - received, 0);
        if (n <= 0) return false;
        received += size_t(n);
    }
    const unsigned kSettingsFrame = 0x4;
    const bool streamZero =
        (header[5] & 0x7f) == 0 && header[6] == 0 && header[7] == 0 && header[8] == 0;
    return header[3] == kSettingsFrame && streamZero;
}

// Whether the server completes a TLS handshake (its certificate is not checked: the question is
// only which protocol it speaks).
bool completesTlsHandshake(const Socket& socket, const std::string& host) {
    std::unique_ptr<SSL_CTX, decltype(&::SSL_CTX_free)> context(::SSL_CTX_new(TLS_client_method()),
                                                                &::SSL_CTX_free);
    if (!context) return false;
    ::SSL_CTX_set_verify(context.get(), SSL_VERIFY_NONE, nullptr);
    std::unique_ptr<SSL, decltype(&::SSL_free)> ssl(::SSL_new(context.get()), &::SSL_free);
    if (!ssl) return false;
    static const unsigned char kAlpnHttp2[] = {2, 'h', '2'};
    ::SSL_set_alpn_protos(ssl.get(), kAlpnHttp2, sizeof kAlpnHttp2);
    ::SSL_set_tlsext_host_name(ssl.get(), host.c_str());
    ::SSL_set_fd(ssl.get(), socket.fd());
    const bool completed = ::SSL_connect(ssl.get()) == 1;
    ::ERR_clear_error();
    return completed;
}

}  // namespace

WireProtocol probeWireProtocol(const std::string& address, std::chrono::milliseconds timeout) {
    const auto half = std::max(std::chrono::milliseconds(1), timeout / 2);
    auto socket = connectTo(address, half);
    if (!socket) return WireProtocol::Unreachable;
    if (sendsHttp2Settings(*socket, half)) return WireProtocol::Plaintext;
    socket = connectTo(address, half);
    std::string host, port;
    if (socket && splitAddress(address, host, port) && completesTlsHandshake(*socket, host))
        return WireProtocol::Tls;
    return WireProtocol::Unknown;
}

std::string protocolMismatchHint(const std::string& address, bool clientUsesTls,
                                 const std::string& caOption) {
    const WireProtocol protocol = probeWireProtocol(address, std::chrono::milliseconds(1000));
    if (!clientUsesTls && protocol == WireProtocol::Tls)
        return absl::StrFormat(
            "the coordinator at %s speaks TLS but this client connects in plaintext: pass the CA "
            "certificate that signed the coordinator's certificate with %s",
            address, caOption);
    if (clientUsesTls && protocol == WireProtocol::Plaintext)
        return absl::StrFormat(
            "the coordinator at %s speaks plaintext (it was started without --tls-cert) but this "
            "client expects TLS: drop %s, or start the coordinator with --tls-cert and --tls-key",
            address, caOption);
    return "";
}

std::shared_ptr<grpc::ServerCredentials> makeServerCredentials(const std::string& certPath,
                                                               const std::string& keyPath) {
    if (certPath.empty() != keyPath.empty())
        fail("--tls-cert and --tls-key must be given together");
    if (certPath.empty()) return grpc::InsecureServerCredentials();
    grpc::SslServerCredentialsOptions options;
    options.pem_key_cert_pairs.push_back({readFile(keyPath), readFile(certPath)});
    checkServerKeyPair(certPath, options.pem_key_cert_pairs[0].cert_chain, keyPath,
                       options.pem_key_cert_pairs[0].private_key);
    return grpc::SslServerCredentials(options);
}

std::unique_ptr<grpc::ClientContext> makeContext(const std::string& token,
                                                 std::chrono::milliseconds timeout,
                                                 bool waitForReady) {
    auto context = std::make_unique<grpc::ClientContext>();
    addBearer(*context, token);
    context->set_wait_for_ready(waitForReady);
    context->set_deadline(std::chrono::system_clock::now() + timeout);
    return context;
}

}  // namespace alphorn::farm
