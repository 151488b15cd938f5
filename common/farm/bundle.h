// Scene bundles: a scene file and every file it references, named by paths relative to a
// bundle root and stored by content hash. Clients gather them, the coordinator and workers
// materialize them into a private directory and load the scene from there.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace alphorn::farm {

struct BundleEntry {
    std::string path;    // relative, '/'-separated, never absolute or with ".."
    std::string sha256;  // lowercase hex
    uint64_t size = 0;
    std::string sourcePath;  // where the client read it from (not sent)
};

struct Bundle {
    std::vector<BundleEntry> files;
    std::string scenePath;  // one of files[i].path
    uint64_t totalSize() const;
};

// Throws Error unless `path` is a safe bundle path: nonempty, relative, no "." or ".."
// components, no empty components, no backslashes or NUL bytes.
void validateBundlePath(const std::string& path);
// Throws Error on a bad path or hash, a duplicate path, or a scene path not in the bundle.
void validateBundle(const Bundle& bundle);

// Lists the files the scene names without building it (listSceneFiles: the parser's file:line
// errors, and a file that cannot be opened refused naming its element; what only loading the
// scene finds is left to the coordinator, which loads it at submit) and hashes the scene and
// every file it references.
// The bundle root is the deepest directory containing all of them, so paths never need "..":
// a scene may reach "../meshes". Refuses a scene that names a file by an absolute path, which
// the farm would refuse (it resolves files only inside the bundle). Files are placed by the
// paths the scene names them by, not where symbolic links lead, so the farm finds them there.
Bundle gatherBundle(const std::string& scenePath);

// Creates `directory`/path for every file, hard-linking (or copying) the blob that
// blobPath(sha256) names. Returns the path of the scene file inside `directory`. Messages name
// files by their bundle paths, never by where the blobs or `directory` lie.
std::string materializeBundle(const Bundle& bundle, const std::string& directory,
                              const std::function<std::string(const std::string&)>& blobPath);

}  // namespace alphorn::farm
