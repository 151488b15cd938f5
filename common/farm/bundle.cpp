#include "common/farm/bundle.h"

#include "common/core/error.h"
#include "common/farm/sha256.h"
#include "common/farm/text_field.h"
#include "common/scene/parser.h"

#include <absl/strings/str_split.h>

#include <filesystem>
#include <map>
#include <set>

namespace alphorn::farm {

namespace fs = std::filesystem;

uint64_t Bundle::totalSize() const {
    uint64_t total = 0;
    for (const BundleEntry& file : files) total += file.size;
    return total;
}

void validateBundlePath(const std::string& path) {
    if (path.empty()) fail("bundle path is empty");
    checkTextField("a bundle path", path, 4096);
    if (path.front() == '/') fail("bundle path \"%s\" is absolute; paths must be relative", path);
    if (path.find('\\') != std::string::npos) fail("bundle path \"%s\" contains a backslash", path);
    for (absl::string_view part : absl::StrSplit(path, '/')) {
        if (part == "..")
            fail("bundle path \"%s\" contains \"..\"; paths may not leave the bundle", path);
        if (part.empty() || part == ".")
            fail("bundle path \"%s\" has an empty or \".\" component", path);
    }
}

void validateBundle(const Bundle& bundle) {
    std::set<std::string> paths;
    for (const BundleEntry& file : bundle.files) {
        validateBundlePath(file.path);
        if (!isSha256Hex(file.sha256))
            fail("bundle file \"%s\": \"%s\" is not a lowercase hex SHA-256", file.path,
                 file.sha256);
        if (!paths.insert(file.path).second) fail("bundle path \"%s\" appears twice", file.path);
    }
    // A file and a directory of the same name cannot both be materialized.
    for (const std::string& path : paths)
        for (size_t slash = path.find('/'); slash != std::string::npos;
             slash = path.find('/', slash + 1))
            if (paths.count(path.substr(0, slash)))
                fail("bundle path \"%s\" is both a file and a directory", path.substr(0, slash));
    if (!paths.count(bundle.scenePath))
        fail("the scene \"%s\" is not one of the bundle's files", bundle.scenePath);
}

Bundle gatherBundle(const std::string& scenePath) {
    // The farm resolves each file the scene names against the scene's place in the bundle, so
    // an absolute path could not be found there: refuse it now rather than after the upload.
    FileReferencePolicy policy;
    policy.relativeOnly = true;
    // Listed, not loaded: building a scene of many meshes takes long, and the coordinator loads
    // it anyway at submit to check what only loading finds.
    const std::vector<std::string> dependencies = listSceneFiles(scenePath, policy);
    // Paths by name, as the loader opened them (not through symbolic links): the farm finds a
    // file where the scene's relative path leads inside the bundle, so the bundle must hold it
    // there even when the client reached it through a link.
    std::vector<fs::path> files{fs::absolute(scenePath).lexically_normal()};
    for (const std::string& dependency : dependencies)
        files.push_back(fs::absolute(dependency).lexically_normal());

    // The root: the longest common directory prefix of all files.
    fs::path root = files.front().parent_path();
    for (const fs::path& file : files) {
        while (!root.empty()) {
            auto [rootEnd, fileIt] =
                std::mismatch(root.begin(), root.end(), file.begin(), file.end());
            if (rootEnd == root.end()) break;
            root = root.parent_path();
        }
    }

    Bundle bundle;
    std::map<std::string, BundleEntry> byPath;
    for (const fs::path& file : files) {
        BundleEntry entry;
        entry.path = file.lexically_relative(root).generic_string();
        entry.sourcePath = file.string();
        if (byPath.count(entry.path)) continue;
        std::error_code error;
        entry.size = fs::file_size(file, error);
        if (error) fail("%s: cannot read the size: %s", file.string(), error.message());
        entry.sha256 = sha256OfFile(file.string());
        validateBundlePath(entry.path);
        byPath[entry.path] = entry;
    }
    bundle.scenePath = files.front().lexically_relative(root).generic_string();
    for (auto& [path, entry] : byPath) bundle.files.push_back(std::move(entry));
    return bundle;
}

std::string materializeBundle(const Bundle& bundle, const std::string& directory,
                              const std::function<std::string(const std::string&)>& blobPath) {
    validateBundle(bundle);
    // Messages name files by their bundle paths only: on a worker they become the job's error,
    // and where the server keeps blobs and bundles is none of the user's business.
    std::error_code error;
    fs::create_directories(directory, error);
    if (error) fail("cannot create the bundle's directory: %s", error.message());
    for (const BundleEntry& file : bundle.files) {
        const fs::path target = fs::path(directory) / file.path;
        fs::create_directories(target.parent_path(), error);
        if (error) fail("cannot materialize \"%s\": %s", file.path, error.message());
        fs::remove(target, error);
        std::string source;
        try {
            source = blobPath(file.sha256);
        } catch (const fs::filesystem_error& e) {
            fail("cannot fetch \"%s\" (blob %s): %s", file.path, file.sha256, e.code().message());
        }
        fs::create_hard_link(source, target, error);
        if (error) {
            fs::copy_file(source, target, fs::copy_options::overwrite_existing, error);
            if (error) fail("cannot materialize \"%s\": %s", file.path, error.message());
        }
    }
    return (fs::path(directory) / bundle.scenePath).string();
}

}  // namespace alphorn::farm
