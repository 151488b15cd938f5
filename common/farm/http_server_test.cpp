// The daemons' HTTP server on real loopback sockets: bearer tokens, 401 before routing, 404,
// anonymous routes, one listener per port, and HTTPS with a certificate made here.
#include "common/farm/http_server.h"

#include "common/core/error.h"
#include "common/farm/http_test_client.h"
#include "common/farm/tls_testing.h"

#include <gtest/gtest.h>

#include <filesystem>

namespace alphorn::farm {
namespace {

namespace fs = std::filesystem;

const std::string kToken = "0123456789abcdef0123456789abcdef";
const std::string kOtherToken = "fedcba9876543210fedcba9876543210";

HttpHeaders bearer(const std::string& token) {
    return {{"Authorization", "Bearer " + token}};
}

const std::string kViewerToken = "00001111222233334444555566667777";

// /secret opens to kToken and kOtherToken, /view to kViewerToken only, /open to anyone.
void addRoutes(HttpServer& server) {
    server.get("/secret", {{kToken, kOtherToken}}, [](const HttpRequest&, HttpResponse& response) {
        response.setContent("the secret\n", "text/plain");
    });
    server.get("/view", {{kViewerToken}}, [](const HttpRequest&, HttpResponse& response) {
        response.setContent("a view\n", "text/plain");
    });
    server.get("/open", {{}, true}, [](const HttpRequest&, HttpResponse& response) {
        response.setContent("open to all\n", "text/plain");
    });
}

TEST(HttpServerTest, ServesOnlyRequestsWithAnAcceptedToken) {
    HttpServer server({"127.0.0.1:0"});
    addRoutes(server);
    server.start();
    ASSERT_GT(server.port(), 0);
    HttpTestClient client("127.0.0.1", server.port());

    auto ok = client.get("/secret", bearer(kToken));
    ASSERT_TRUE(ok);
    EXPECT_EQ(ok->status, 200);
    EXPECT_EQ(ok->body, "the secret\n");
    auto second = client.get("/secret", bearer(kOtherToken));
    ASSERT_TRUE(second);
    EXPECT_EQ(second->status, 200);

    auto none = client.get("/secret");
    ASSERT_TRUE(none);
    EXPECT_EQ(none->status, 401);
    EXPECT_EQ(none->header("WWW-Authenticate"), "Bearer realm=\"alphorn\"");
    EXPECT_EQ(none->body.find("the secret"), std::string::npos);
    for (const std::string& wrong :
         {kToken.substr(0, 31), kToken + "0", std::string("ffffffffffffffffffffffffffffffff"),
          std::string("")}) {
        auto refused = client.get("/secret", bearer(wrong));
        ASSERT_TRUE(refused);
        EXPECT_EQ(refused->status, 401) << "token \"" << wrong << "\"";
    }
    auto basic = client.get("/secret", {{"Authorization", "Basic " + kToken}});
    ASSERT_TRUE(basic);
    EXPECT_EQ(basic->status, 401);
    server.stop();
}

TEST(HttpServerTest, ATokenOpensOnlyItsRoutes) {
    HttpServer server({"127.0.0.1:0"});
    addRoutes(server);
    server.start();
    HttpTestClient client("127.0.0.1", server.port());
    auto viewer = client.get("/view", bearer(kViewerToken));
    ASSERT_TRUE(viewer);
    EXPECT_EQ(viewer->status, 200);
    auto other = client.get("/secret", bearer(kViewerToken));
    ASSERT_TRUE(other);
    EXPECT_EQ(other->status, 403);
    EXPECT_EQ(other->body.find("the secret"), std::string::npos);
    auto reverse = client.get("/view", bearer(kToken));
    ASSERT_TRUE(reverse);
    EXPECT_EQ(reverse->status, 403);
}

TEST(HttpServerTest, PostRoutesAreGuardedAlike) {
    HttpServer server({"127.0.0.1:0"});
    server.post("/action", {{kToken}}, [](const HttpRequest& request, HttpResponse& response) {
        response.setContent("did " + request.body + "\n", "text/plain");
    });
    server.start();
    HttpTestClient client("127.0.0.1", server.port());
    auto done = client.post("/action", bearer(kToken), "it", "text/plain");
    ASSERT_TRUE(done);
    EXPECT_EQ(done->status, 200);
    EXPECT_EQ(done->body, "did it\n");
    auto refused = client.post("/action", {}, "it", "text/plain");
    ASSERT_TRUE(refused);
    EXPECT_EQ(refused->status, 401);
    EXPECT_EQ(refused->body.find("did"), std::string::npos);
}

TEST(HttpServerTest, ARouteNeedsATokenOrExplicitlyAnyone) {
    HttpServer server({"127.0.0.1:0"});
    const auto handler = [](const HttpRequest&, HttpResponse&) {};
    EXPECT_THROW(server.get("/nobody", {}, handler), Error);
    EXPECT_THROW(server.get("/empty", {{""}}, handler), Error);
}

TEST(HttpServerTest, UnknownPathsAre401WithoutATokenAnd404WithOne) {
    HttpServer server({"127.0.0.1:0"});
    addRoutes(server);
    server.start();
    HttpTestClient client("127.0.0.1", server.port());
    auto anonymous = client.get("/nothing-here");
    ASSERT_TRUE(anonymous);
    EXPECT_EQ(anonymous->status, 401);
    auto known = client.get("/nothing-here", bearer(kToken));
    ASSERT_TRUE(known);
    EXPECT_EQ(known->status, 404);
    EXPECT_EQ(known->body, "404 not found: /nothing-here\n");
    // Paths are literal, not regular expressions: "/secre." does not reach "/secret".
    auto pattern = client.get("/secre.", bearer(kToken));
    ASSERT_TRUE(pattern);
    EXPECT_EQ(pattern->status, 404);
}

TEST(HttpServerTest, AnonymousRoutesNeedNoToken) {
    HttpServer server({"127.0.0.1:0"});
    addRoutes(server);
    server.start();
    HttpTestClient client("127.0.0.1", server.port());
    auto open = client.get("/open");
    ASSERT_TRUE(open);
    EXPECT_EQ(open->status, 200);
    EXPECT_EQ(open->body, "open to all\n");
    auto secret = client.get("/secret");
    ASSERT_TRUE(secret);
    EXPECT_EQ(secret->status, 401);
}

TEST(HttpServerTest, ASecondServerCannotTakeTheSamePort) {
    HttpServer first({"127.0.0.1:0"});
    first.start();
    HttpServer second({"127.0.0.1:" + std::to_string(first.port())});
    try {
        second.start();
        FAIL() << "a second server listened on the same port";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("cannot listen on 127.0.0.1:"), std::string::npos)
            << e.what();
    }
}

TEST(HttpServerTest, BadAddressesAreRefusedClearly) {
    EXPECT_THROW(HttpServer({"127.0.0.1"}), Error);
    EXPECT_THROW(HttpServer({"127.0.0.1:99999"}), Error);
    EXPECT_THROW(HttpServer({"127.0.0.1:http"}), Error);
    EXPECT_EQ(splitHostPort("[::1]:9100"), std::make_pair(std::string("::1"), 9100));
    EXPECT_EQ(splitHostPort("0.0.0.0:0"), std::make_pair(std::string("0.0.0.0"), 0));
}

TEST(HttpServerTest, ServesHttpsWithTheDaemonsCertificate) {
    const TestCertificate files = makeCertificate(fs::path(testing::TempDir()) / "http_tls");
    HttpServer server({"127.0.0.1:0", files.certPath, files.keyPath});
    ASSERT_TRUE(server.tls());
    addRoutes(server);
    server.start();

    HttpTestClient client("127.0.0.1", server.port(), files.certPath);
    auto ok = client.get("/secret", bearer(kToken));
    ASSERT_TRUE(ok) << client.lastError();
    EXPECT_EQ(ok->status, 200);
    EXPECT_EQ(ok->body, "the secret\n");
    auto refused = client.get("/secret");
    ASSERT_TRUE(refused);
    EXPECT_EQ(refused->status, 401);

    // A plaintext request gets no HTTP answer from the TLS port.
    HttpTestClient plain("127.0.0.1", server.port());
    plain.setTimeout(2);
    auto plainAnswer = plain.get("/secret", bearer(kToken));
    EXPECT_FALSE(plainAnswer && plainAnswer->status == 200);
}

TEST(HttpServerTest, ACertificateThatDoesNotLoadIsNamed) {
    const TestCertificate files = makeCertificate(fs::path(testing::TempDir()) / "http_tls_bad");
    const std::string missing = (fs::path(testing::TempDir()) / "missing.pem").string();
    try {
        HttpServer server({"127.0.0.1:0", missing, files.keyPath});
        FAIL() << "a missing certificate was accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
    }
    const TestCertificate other = makeCertificate(fs::path(testing::TempDir()) / "http_tls_other");
    try {
        HttpServer server({"127.0.0.1:0", files.certPath, other.keyPath});
        FAIL() << "a key of another certificate was accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(other.keyPath), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("mismatch"), std::string::npos) << e.what();
    }
    EXPECT_THROW(HttpServer({"127.0.0.1:0", files.certPath, ""}), Error);
}

}  // namespace
}  // namespace alphorn::farm
