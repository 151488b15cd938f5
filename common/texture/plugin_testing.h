// Helpers for the plugin unit tests: build plugins from XML snippets through the real parser, so
// tests see exactly what a scene file gets (including file:line in error messages).
#pragma once

#include "common/core/object.h"
#include "common/scene/parser.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace alphorn::plugin_testing {

// A directory private to this test process, removed at exit. ctest runs every test case as its
// own process in parallel, so a shared name such as /tmp/texture.xml would be written by one
// case while another parses it.
inline const std::filesystem::path& processTempDir() {
    struct OwnedDir {
        std::filesystem::path path;
        OwnedDir()
            : path(std::filesystem::path(::testing::TempDir()) /
                   ("alphorn-plugin-test-" + std::to_string(::getpid()))) {
            std::filesystem::create_directories(path);
        }
        ~OwnedDir() {
            std::error_code ignored;
            std::filesystem::remove_all(path, ignored);
        }
    };
    static const OwnedDir dir;
    return dir.path;
}

// Writes `text` to a file in this process's temp directory and returns its path.
inline std::string writeTempFile(const std::string& name, const std::string& text) {
    const std::string path = (processTempDir() / name).string();
    std::ofstream(path) << text;
    return path;
}

// Parses an XML file whose root is one plugin (<texture>, <bsdf>, <emitter>, ...).
template <typename T>
std::shared_ptr<T> parseAs(const std::string& name, const std::string& xml) {
    auto object = std::dynamic_pointer_cast<T>(parseSceneFile(writeTempFile(name, xml)).root);
    EXPECT_TRUE(object != nullptr) << name;
    return object;
}

// Expects parsing to throw an Error that names "<file>:<line>:" and contains `what`.
inline void expectParseError(const std::string& name, const std::string& xml, int line,
                             const std::string& what) {
    const std::string path = writeTempFile(name, xml);
    try {
        parseSceneFile(path);
        ADD_FAILURE() << name << ": no error";
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find(path + ":" + std::to_string(line) + ":"), std::string::npos)
            << message;
        EXPECT_NE(message.find(what), std::string::npos) << message;
    }
}

}  // namespace alphorn::plugin_testing
