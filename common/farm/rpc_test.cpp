#include "common/farm/rpc.h"

#include "common/core/error.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>

namespace alphorn::farm {
namespace {

namespace fs = std::filesystem;

std::string writeToken(const std::string& name, fs::perms permissions) {
    const fs::path path = fs::path(testing::TempDir()) / name;
    std::ofstream(path) << "0123456789abcdef0123456789abcdef\n";
    fs::permissions(path, permissions);
    return path.string();
}

TEST(TokenFileTest, WarnsOnlyWhenGroupOrOthersCanRead) {
    EXPECT_EQ(tokenPermissionWarning("t", 0100600), "");
    EXPECT_EQ(tokenPermissionWarning("t", 0100400), "");
    EXPECT_EQ(tokenPermissionWarning("t", 0100620), "");  // group may write, not read: no leak
    EXPECT_NE(tokenPermissionWarning("t", 0100640).find("readable by its group (mode 0640)"),
              std::string::npos);
    EXPECT_NE(tokenPermissionWarning("t", 0100604).find("readable by others (mode 0604)"),
              std::string::npos);
    const std::string both = tokenPermissionWarning("/etc/alphorn/client.token", 0100644);
    EXPECT_NE(both.find("readable by its group and others (mode 0644)"), std::string::npos);
    EXPECT_NE(both.find("chmod 600 /etc/alphorn/client.token"), std::string::npos);
}

TEST(TokenFileTest, ReadingAWorldReadableTokenWarnsOnceOnStderr) {
    const std::string path =
        writeToken("world_readable.token", fs::perms::owner_read | fs::perms::owner_write |
                                               fs::perms::group_read | fs::perms::others_read);
    testing::internal::CaptureStderr();
    EXPECT_EQ(readTokenFile(path), "0123456789abcdef0123456789abcdef");
    EXPECT_EQ(readTokenFile(path), "0123456789abcdef0123456789abcdef");
    const std::string printed = testing::internal::GetCapturedStderr();
    EXPECT_NE(printed.find("warning: the token file " + path), std::string::npos) << printed;
    EXPECT_EQ(printed.find("warning", 1), std::string::npos) << "warned twice: " << printed;
}

TEST(TokenFileTest, ReadingAPrivateTokenPrintsNothing) {
    const std::string path =
        writeToken("private.token", fs::perms::owner_read | fs::perms::owner_write);
    testing::internal::CaptureStderr();
    EXPECT_EQ(readTokenFile(path), "0123456789abcdef0123456789abcdef");
    EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

TEST(TokenFileTest, ShortTokensAreRefused) {
    const std::string path = fs::path(testing::TempDir()) / "short.token";
    std::ofstream(path) << "tooshort\n";
    fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write);
    EXPECT_THROW(readTokenFile(path), Error);
}

TEST(WireProtocolTest, NothingListeningIsUnreachable) {
    EXPECT_EQ(probeWireProtocol("127.0.0.1:1", std::chrono::milliseconds(500)),
              WireProtocol::Unreachable);
    EXPECT_EQ(probeWireProtocol("no port here", std::chrono::milliseconds(500)),
              WireProtocol::Unreachable);
    EXPECT_EQ(protocolMismatchHint("127.0.0.1:1", false, "--tls-ca"), "");
}

}  // namespace
}  // namespace alphorn::farm
