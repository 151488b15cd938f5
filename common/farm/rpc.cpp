#include "common/farm/rpc.h"

#include "common/core/error.h"
#include "common/farm/files.h"

#include <absl/strings/ascii.h>
#include <openssl/crypto.h>
#include <openssl/rand.h>

namespace alphorn::farm {

std::string readTokenFile(const std::string& path) {
    std::string text = readFile(path);
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

std::shared_ptr<grpc::Channel> makeChannel(const std::string& address,
                                           const std::string& caCertPath) {
    grpc::ChannelArguments arguments;
    arguments.SetMaxReceiveMessageSize(kMaxMessageBytes);
    arguments.SetMaxSendMessageSize(kMaxMessageBytes);
    // Reconnect quickly after a coordinator restart (the default backoff grows to minutes).
    arguments.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 2000);
    arguments.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 200);
    arguments.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 200);
    std::shared_ptr<grpc::ChannelCredentials> credentials;
    if (caCertPath.empty()) {
        credentials = grpc::InsecureChannelCredentials();
    } else {
        grpc::SslCredentialsOptions options;
        options.pem_root_certs = readFile(caCertPath);
        credentials = grpc::SslCredentials(options);
    }
    return grpc::CreateCustomChannel(address, credentials, arguments);
}

std::shared_ptr<grpc::ServerCredentials> makeServerCredentials(const std::string& certPath,
                                                               const std::string& keyPath) {
    if (certPath.empty() != keyPath.empty())
        fail("--tls-cert and --tls-key must be given together");
    if (certPath.empty()) return grpc::InsecureServerCredentials();
    grpc::SslServerCredentialsOptions options;
    options.pem_key_cert_pairs.push_back({readFile(keyPath), readFile(certPath)});
    return grpc::SslServerCredentials(options);
}

std::unique_ptr<grpc::ClientContext> makeContext(const std::string& token,
                                                 std::chrono::milliseconds timeout) {
    auto context = std::make_unique<grpc::ClientContext>();
    addBearer(*context, token);
    context->set_deadline(std::chrono::system_clock::now() + timeout);
    return context;
}

}  // namespace alphorn::farm
