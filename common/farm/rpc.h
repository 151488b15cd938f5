// What every farm program needs around gRPC: bearer tokens, channels with optional TLS, and the
// message size limits (results and images are streamed in chunks well under them).
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <memory>
#include <string>

namespace alphorn::farm {

// Stream chunks stay at 1 MiB, far below gRPC's 4 MiB default message limit.
inline constexpr size_t kChunkBytes = 1 << 20;
// Largest single message either side accepts (a chunk plus headers, with room to spare).
inline constexpr int kMaxMessageBytes = 8 << 20;

// Reads a token file: the first line, surrounding whitespace removed. Throws Error when the
// file is missing, empty or shorter than 16 characters (a guessable token is a configuration bug).
std::string readTokenFile(const std::string& path);
// A random 256-bit token in hex (for `alphorn cluster` and tests).
std::string generateToken();

// OK when the call carries "authorization: Bearer <expected>" (compared in constant time),
// UNAUTHENTICATED otherwise.
grpc::Status checkBearer(const grpc::ServerContext& context, const std::string& expected);
void addBearer(grpc::ClientContext& context, const std::string& token);

// A channel to `address`; with a non-empty `caCertPath`, TLS verifying the server against it.
std::shared_ptr<grpc::Channel> makeChannel(const std::string& address,
                                           const std::string& caCertPath);
// Server credentials: TLS from PEM files when both are given, plaintext otherwise.
std::shared_ptr<grpc::ServerCredentials> makeServerCredentials(const std::string& certPath,
                                                               const std::string& keyPath);

// A client context with the bearer token and a deadline.
std::unique_ptr<grpc::ClientContext> makeContext(const std::string& token,
                                                 std::chrono::milliseconds timeout);

}  // namespace alphorn::farm
