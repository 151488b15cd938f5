// Fuzzes bundle manifests as the coordinator receives them in SubmitJob: a v1::BundleManifest
// parsed from bytes, fromProto(), validateBundle(); a manifest that passes is materialized into
// a scratch directory, where every file must land inside that directory.
#include "common/core/error.h"
#include "common/farm/convert.h"
#include "fuzz/fuzz_support.h"

#include <cstdio>
#include <cstdlib>

namespace fs = std::filesystem;

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    // protobuf logs every string field that is not UTF-8; the parse failure is all that counts.
    google::protobuf::SetLogHandler(nullptr);
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace alphorn;
    v1::BundleManifest manifest;
    if (!manifest.ParseFromArray(data, static_cast<int>(size))) return 0;
    const farm::Bundle bundle = farm::fromProto(manifest);
    try {
        farm::validateBundle(bundle);
    } catch (const Error&) {
        return 0;
    }
    const fs::path directory = fs::path(fuzz::scratchDirectory()) / "bundle";
    const std::string blob = fuzz::scratchDirectory() + "/blob";
    if (!fs::exists(blob)) fuzz::writeFile(blob, "blob");
    try {
        farm::materializeBundle(bundle, directory.string(),
                                [&](const std::string&) { return blob; });
    } catch (const Error&) {
    }
    // Every path below the directory must be one of the bundle's files or their parents.
    const fs::path root = fs::weakly_canonical(directory);
    for (const farm::BundleEntry& file : bundle.files) {
        const fs::path landed = fs::weakly_canonical(directory / file.path);
        const auto [rootEnd, ignored] =
            std::mismatch(root.begin(), root.end(), landed.begin(), landed.end());
        if (rootEnd != root.end()) {
            std::fprintf(stderr, "bundle file \"%s\" escaped the bundle directory\n",
                         file.path.c_str());
            std::abort();
        }
    }
    fs::remove_all(directory);
    return 0;
}
