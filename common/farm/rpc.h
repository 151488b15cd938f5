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
// Warns (alphorn::warn(): on stderr, or in a daemon's log), once per path, when the file is
// readable by its group or by others.
std::string readTokenFile(const std::string& path);
// The warning readTokenFile() prints for a file with these permission bits; empty when only the
// owner can read it.
std::string tokenPermissionWarning(const std::string& path, unsigned mode);
// A random 256-bit token in hex (for `alphorn cluster` and tests).
std::string generateToken();

// OK when the call carries "authorization: Bearer <expected>" (compared in constant time),
// UNAUTHENTICATED otherwise.
grpc::Status checkBearer(const grpc::ServerContext& context, const std::string& expected);
void addBearer(grpc::ClientContext& context, const std::string& token);

// A channel to `address`; with a non-empty `caCertPath`, TLS verifying the server against it.
// Its connection attempts get gRPC's full connect timeout (20 s, so a busy coordinator is not
// given up on while it answers hundreds of clients), reconnect within a second once the
// coordinator is back, and send keepalive pings so a vanished coordinator is noticed.
std::shared_ptr<grpc::Channel> makeChannel(const std::string& address,
                                           const std::string& caCertPath);
// Server options matching makeChannel(): the keepalive pings clients send are welcome.
void configureServer(grpc::ServerBuilder& builder);

// What the server at `address` speaks, found with plain sockets outside gRPC so that a client
// configured for the other protocol can be told what to change.
enum class WireProtocol { Unreachable, Plaintext, Tls, Unknown };
WireProtocol probeWireProtocol(const std::string& address, std::chrono::milliseconds timeout);
// When the coordinator at `address` speaks the other protocol than the client (TLS when
// `clientUsesTls` is false, plaintext when true), a sentence saying so and what to pass;
// empty otherwise. `caOption` names the client's CA option (e.g. "--tls-ca or ALPHORN_TLS_CA").
std::string protocolMismatchHint(const std::string& address, bool clientUsesTls,
                                 const std::string& caOption);
// Server credentials: TLS from PEM files when both are given, plaintext otherwise.
std::shared_ptr<grpc::ServerCredentials> makeServerCredentials(const std::string& certPath,
                                                               const std::string& keyPath);

// A client context with the bearer token and a deadline. With `waitForReady` (the default), a
// call made while the coordinator is unreachable waits for it until the deadline instead of
// failing at once. That matters beyond patience: gRPC's synchronous API moves a connection
// attempt (TCP connect, TLS handshake, HTTP/2 settings) forward only while some thread of the
// process waits in a call. A call that fails at once leaves nobody polling, the attempt stalls
// until gRPC's 5-second backup poller and is abandoned at its deadline: a TLS handshake, which
// needs several round trips, then never completed after a coordinator restart.
std::unique_ptr<grpc::ClientContext> makeContext(const std::string& token,
                                                 std::chrono::milliseconds timeout,
                                                 bool waitForReady = true);

}  // namespace alphorn::farm
