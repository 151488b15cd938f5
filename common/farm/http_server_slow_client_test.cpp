// The daemons' HTTP server against clients that are slow on purpose: connections that send part
// of a request and then nothing, or a byte at a time, TLS connections that never shake hands, and
// more connections than the server admits. None may hold the server: other requests are still
// answered at once, a request that does not arrive whole within its deadline is dropped, and
// connections beyond the caps are closed right away.
#include "common/farm/http_server.h"
#include "common/farm/http_test_client.h"
#include "common/farm/tls_testing.h"

#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <arpa/inet.h>
#include <chrono>
#include <filesystem>
#include <thread>

namespace alphorn::farm {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}

// A raw TCP connection to the server, from `source` (any address of 127/8 is this machine).
class RawConnection {
  public:
    explicit RawConnection(int port, const char* source = "127.0.0.1") {
        m_fd = socket(AF_INET, SOCK_STREAM, 0);
        sockaddr_in address{};
        address.sin_family = AF_INET;
        inet_pton(AF_INET, source, &address.sin_addr);
        EXPECT_EQ(bind(m_fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
        address.sin_port = htons(uint16_t(port));
        inet_pton(AF_INET, "127.0.0.1", &address.sin_addr);
        EXPECT_EQ(connect(m_fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
    }
    ~RawConnection() { close(m_fd); }
    RawConnection(const RawConnection&) = delete;
    RawConnection& operator=(const RawConnection&) = delete;

    // False once the server has closed the connection.
    bool send(const std::string& bytes) {
        return ::send(m_fd, bytes.data(), bytes.size(), MSG_NOSIGNAL) == ssize_t(bytes.size());
    }
    // Whether the server closes the connection within `seconds` (reading and dropping what it
    // sends before that).
    bool closedWithin(double seconds) {
        const Clock::time_point start = Clock::now();
        while (secondsSince(start) < seconds) {
            pollfd entry{m_fd, POLLIN, 0};
            if (poll(&entry, 1, 50) == 1) {
                char buffer[4096];
                if (recv(m_fd, buffer, sizeof buffer, 0) <= 0) return true;
            }
        }
        return false;
    }
    // Reads until a response's head has come; returns its status line.
    std::string readHead(double seconds) {
        std::string received;
        const Clock::time_point start = Clock::now();
        while (received.find("\r\n\r\n") == std::string::npos && secondsSince(start) < seconds) {
            pollfd entry{m_fd, POLLIN, 0};
            if (poll(&entry, 1, 50) != 1) continue;
            char buffer[4096];
            const ssize_t size = recv(m_fd, buffer, sizeof buffer, 0);
            if (size <= 0) break;
            received.append(buffer, size_t(size));
        }
        return received.substr(0, received.find("\r\n"));
    }

  private:
    int m_fd = -1;
};

const std::string kPartialRequest = "GET /open HTTP/1.1\r\nHost: 127.0.0.1\r\n";

void addOpenRoute(HttpServer& server) {
    // Only `status`: the request and response types are not this test's subject.
    server.get("/open", {{}, true}, [](const auto&, auto& response) { response.status = 200; });
}

// Many more stalled clients than threads, and a deadline far longer than the test: only a
// server that holds no thread for a waiting connection answers the last request at once.
TEST(HttpServerSlowClientTest, StalledRequestsDoNotDelayOthers) {
    HttpServerOptions options{"127.0.0.1:0"};
    options.threads = 2;
    options.requestSeconds = 60;
    HttpServer server(options);
    addOpenRoute(server);
    server.start();
    std::vector<std::unique_ptr<RawConnection>> stalled;
    for (int i = 0; i < 12; ++i) {
        stalled.push_back(std::make_unique<RawConnection>(server.port()));
        EXPECT_TRUE(stalled.back()->send(kPartialRequest));
    }
    HttpTestClient client("127.0.0.1", server.port());
    client.setTimeout(4);
    const Clock::time_point start = Clock::now();
    auto answer = client.get("/open");
    ASSERT_TRUE(answer) << client.lastError();
    EXPECT_EQ(answer->status, 200);
    EXPECT_LT(secondsSince(start), 2.0);
    stalled.clear();  // before the server stops
}

TEST(HttpServerSlowClientTest, SilentTlsConnectionsDoNotDelayOthers) {
    const TestCertificate files = makeCertificate(fs::path(testing::TempDir()) / "http_slow_tls");
    HttpServerOptions options{"127.0.0.1:0", files.certPath, files.keyPath};
    options.threads = 2;
    options.requestSeconds = 60;
    HttpServer server(options);
    addOpenRoute(server);
    server.start();
    std::vector<std::unique_ptr<RawConnection>> silent;
    for (int i = 0; i < 12; ++i) silent.push_back(std::make_unique<RawConnection>(server.port()));
    HttpTestClient client("127.0.0.1", server.port(), files.certPath);
    client.setTimeout(4);
    const Clock::time_point start = Clock::now();
    auto answer = client.get("/open");
    ASSERT_TRUE(answer) << client.lastError();
    EXPECT_EQ(answer->status, 200);
    EXPECT_LT(secondsSince(start), 2.0);
    silent.clear();
}

// Each byte comes well within any per-read timeout; the request as a whole never does.
TEST(HttpServerSlowClientTest, ARequestTricklingInIsDroppedAtItsDeadline) {
    HttpServerOptions options{"127.0.0.1:0"};
    options.requestSeconds = 1;
    HttpServer server(options);
    addOpenRoute(server);
    server.start();
    RawConnection trickle(server.port());
    const Clock::time_point start = Clock::now();
    const std::string request = kPartialRequest + "X-Slow: " + std::string(1000, 'a');
    bool closed = false;
    for (size_t i = 0; i < request.size() && !closed && secondsSince(start) < 5; ++i)
        closed = !trickle.send(request.substr(i, 1)) || trickle.closedWithin(0.1);
    EXPECT_TRUE(closed) << "still open after " << secondsSince(start) << " s";
    EXPECT_GT(secondsSince(start), 0.5);  // at the deadline, not before
}

TEST(HttpServerSlowClientTest, ASilentTlsConnectionIsDroppedAtItsDeadline) {
    const TestCertificate files =
        makeCertificate(fs::path(testing::TempDir()) / "http_slow_tls_deadline");
    HttpServerOptions options{"127.0.0.1:0", files.certPath, files.keyPath};
    options.requestSeconds = 1;
    HttpServer server(options);
    addOpenRoute(server);
    server.start();
    RawConnection silent(server.port());
    EXPECT_TRUE(silent.closedWithin(4));
}

TEST(HttpServerSlowClientTest, AnIdleKeptAliveConnectionIsClosed) {
    HttpServerOptions options{"127.0.0.1:0"};
    options.idleSeconds = 0.5;
    HttpServer server(options);
    addOpenRoute(server);
    server.start();
    RawConnection connection(server.port());
    ASSERT_TRUE(connection.send(kPartialRequest + "\r\n"));
    EXPECT_EQ(connection.readHead(4), "HTTP/1.1 200 OK");
    EXPECT_TRUE(connection.closedWithin(3));
}

TEST(HttpServerSlowClientTest, ConnectionsBeyondTheCapsAreClosedAtOnce) {
    HttpServerOptions options{"127.0.0.1:0"};
    options.maxConnectionsPerAddress = 2;
    options.maxConnections = 4;
    options.requestSeconds = 60;
    HttpServer server(options);
    addOpenRoute(server);
    server.start();
    // Connections are accepted in the order they were made: the first two are admitted.
    std::vector<std::unique_ptr<RawConnection>> held;
    for (int i = 0; i < 2; ++i) {
        held.push_back(std::make_unique<RawConnection>(server.port(), "127.0.0.1"));
        held.back()->send(kPartialRequest);
    }
    RawConnection third(server.port(), "127.0.0.1");
    EXPECT_TRUE(third.closedWithin(3)) << "a third connection from one address stayed open";
    // Another address still gets its answer...
    RawConnection other(server.port(), "127.0.0.2");
    ASSERT_TRUE(other.send(kPartialRequest + "Connection: close\r\n\r\n"));
    EXPECT_EQ(other.readHead(4), "HTTP/1.1 200 OK");
    ASSERT_TRUE(other.closedWithin(3));
    // The server gives its place back right after closing it; leave it the moment to.
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    // ... until the server holds its total: 2 + 2 connections.
    for (int i = 0; i < 2; ++i) {
        held.push_back(std::make_unique<RawConnection>(server.port(), "127.0.0.2"));
        held.back()->send(kPartialRequest);
    }
    RawConnection fifth(server.port(), "127.0.0.3");
    EXPECT_TRUE(fifth.closedWithin(3)) << "a fifth connection stayed open";
    held.clear();
}

}  // namespace
}  // namespace alphorn::farm
