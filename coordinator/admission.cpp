#include "coordinator/admission.h"

#include "common/farm/build_identity.h"
#include "common/farm/bundle.h"
#include "common/farm/convert.h"
#include "common/farm/engine_fingerprint.h"
#include "common/farm/files.h"
#include "common/farm/job_scene.h"
#include "common/farm/rpc.h"
#include "common/farm/text_field.h"
#include "common/integrator/integrator.h"
#include "common/photon/radius_schedule.h"
#include "common/render/error_estimate.h"
#include "common/scene/scene.h"
#include "coordinator/farm_error.h"

#include <absl/strings/ascii.h>
#include <absl/strings/str_format.h>
#include <absl/strings/str_replace.h>

#include <algorithm>
#include <filesystem>

namespace alphorn::coordinator {

namespace fs = std::filesystem;
using Kind = FarmError::Kind;

namespace {

// A job's request (its settings and the bundle's file list) and the description made of it go to
// every worker with the job's units in one message, under gRPC's 8 MiB limit on both sides.
constexpr size_t kMaxJobRequestBytes = size_t(4) << 20;

// Passes per unit when the client leaves it to the coordinator. Units of at least ~64k samples
// keep the per-unit cost (two round trips, compression, merge) near 1% of rendering, while at
// least 4 pass chunks keep previews progressive.
uint32_t defaultPassesPerUnit(const v1::JobSettings& settings, const Vector2i& size,
                              uint32_t minimum) {
    const uint64_t tilePixels = std::min<uint64_t>(
        uint64_t(settings.tile_size()) * settings.tile_size(), uint64_t(size.x()) * size.y());
    const uint64_t bySamples = std::max<uint64_t>(1, 65536 / std::max<uint64_t>(1, tilePixels));
    const uint64_t byPreview = std::max<uint64_t>(1, settings.passes() / 4);
    return static_cast<uint32_t>(std::max<uint64_t>(minimum, std::min(bySamples, byPreview)));
}

// An id a client chose for a call it may send again: it is stored, logged and compared, and a
// client sends a random hex string.
void checkClientChosenId(const std::string& id, const char* name) {
    constexpr size_t kMaxIdChars = 64;
    const bool wellFormed =
        id.size() <= kMaxIdChars && std::all_of(id.begin(), id.end(), [](char c) {
            return absl::ascii_isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
        });
    if (!wellFormed)
        throw FarmError(Kind::InvalidArgument,
                        absl::StrFormat("the %s must be at most %u characters of 0-9, A-Z, a-z, "
                                        "_ and - (got %u bytes)",
                                        name, kMaxIdChars, id.size()));
}

// Removes a refused job's staging directory. On a failing disk that may fail too: the next start
// empties the staging area, and the refusal is what the client must hear.
void removeStaging(const std::string& directory) {
    std::error_code ignored;
    fs::remove_all(directory, ignored);
}

}  // namespace

void checkSubmissionId(const std::string& submissionId) {
    checkClientChosenId(submissionId, "submission id");
}

void checkRequestId(const std::string& requestId) {
    checkClientChosenId(requestId, "request id");
}

AdmittedJob admitJob(const v1::SubmitJobRequest& request, const BlobStore& blobs,
                     const AdmissionLimits& limits, const std::string& stagingParent) {
    farm::Bundle bundle = farm::fromProto(request.bundle());
    try {
        farm::validateBundle(bundle);
        farm::checkTextField("the job's name", request.settings().name());
        farm::checkTextField("the job's owner", request.settings().owner());
        farm::checkTextField("the integrator override", request.settings().integrator_override(),
                             64);
        farm::checkEngineFingerprint(request.settings().engine_fingerprint(), true);
    } catch (const Error& e) {
        throw FarmError(Kind::InvalidArgument, e.what());
    }
    // Larger, every worker that leased the job would fail to receive it.
    if (request.ByteSizeLong() > kMaxJobRequestBytes)
        throw FarmError(
            Kind::InvalidArgument,
            absl::StrFormat("the job's request is %u bytes (its bundle lists %u files); "
                            "at most %u are allowed",
                            request.ByteSizeLong(), bundle.files.size(), kMaxJobRequestBytes));
    uint64_t total = 0;
    for (const farm::BundleEntry& file : bundle.files) {
        if (!blobs.has(file.sha256))
            throw FarmError(
                Kind::FailedPrecondition,
                absl::StrFormat("blob %s (%s) has not been uploaded", file.sha256, file.path));
        const uint64_t size = blobs.size(file.sha256);
        if (size != file.size)
            throw FarmError(Kind::InvalidArgument,
                            absl::StrFormat("%s: the manifest says %u bytes, the blob has %u",
                                            file.path, file.size, size));
        total += size;
    }
    if (total > limits.maxBundleBytes)
        throw FarmError(Kind::ResourceExhausted,
                        absl::StrFormat("the bundle has %u bytes, more than the limit of %u", total,
                                        limits.maxBundleBytes));

    // Materialize and load the scene now, so a broken scene fails at submit with the loader's
    // "file:line: problem", with paths as the client knows them (relative to the bundle). Every
    // file is read and checked as the workers will, but no BVH is built: what the job needs
    // from the scene (image size, sampler, filter, radius schedule) does not depend on it.
    AdmittedJob admitted;
    admitted.stagingDirectory =
        (fs::path(stagingParent) / farm::generateToken().substr(0, 16)).string();
    const std::string bundleDirectory = admitted.stagingDirectory + "/bundle";
    v1::JobSettings settings = request.settings();
    std::shared_ptr<Scene> scene;
    try {
        const std::string scenePath = farm::materializeBundle(
            bundle, bundleDirectory, [&](const std::string& sha) { return blobs.pathOf(sha); });
        scene = farm::loadJobScene(bundleDirectory, scenePath, settings.integrator_override(),
                                   {limits.maxGeometryBytes, "--max-memory"}, SceneUse::Check);
    } catch (const Error& e) {
        removeStaging(admitted.stagingDirectory);
        const std::string message = absl::StrReplaceAll(e.what(), {{bundleDirectory + "/", ""}});
        if (dynamic_cast<const ResourceLimitError*>(&e))
            throw FarmError(Kind::ResourceExhausted, message);
        // The coordinator's own disk failing (full, read-only, I/O errors) is not the scene's
        // fault, and the client must not be told it is.
        const std::string diskProblem = farm::directoryWriteProblem(stagingParent);
        if (!diskProblem.empty())
            throw FarmError(Kind::ResourceExhausted,
                            absl::StrFormat("the coordinator's state directory cannot be written "
                                            "(%s), so the job cannot be staged: %s",
                                            diskProblem, message));
        throw FarmError(Kind::InvalidArgument, message);
    }
    const Vector2i size = scene->camera()->outputSize();
    if (settings.has_target_error()) {
        const double target = settings.target_error();
        std::string problem;
        if (!(target > 0.0 && target <= 1.0))
            problem =
                absl::StrFormat("target error %g must be in (0, 1] (a relative RMSE)", target);
        else if (settings.passes() == 0)
            problem = "a target error needs a cap: give the most passes (--max-passes)";
        if (!problem.empty()) {
            removeStaging(admitted.stagingDirectory);
            throw FarmError(Kind::InvalidArgument, problem);
        }
    }
    if (settings.adaptive() && !settings.has_target_error()) {
        removeStaging(admitted.stagingDirectory);
        throw FarmError(Kind::InvalidArgument, "adaptive passes need a target error");
    }
    if (settings.passes() == 0)
        settings.set_passes(static_cast<uint32_t>(scene->sampler()->sampleCount()));
    if (settings.tile_size() == 0) settings.set_tile_size(limits.defaultTileSize);
    // Only workers of this fingerprint render the job: the coordinator's build unless the
    // client pinned another (a farm moving between builds).
    if (settings.engine_fingerprint().empty())
        settings.set_engine_fingerprint(farm::engineFingerprint());
    // An adaptive job's units each lie in one tile of the fixed adaptive grid: the tile size is
    // the largest power of two not above the setting and the grid's (it does not change the image).
    if (settings.adaptive()) {
        uint32_t tile = 1;
        while (tile * 2 <= std::min<uint32_t>(kAdaptiveTileSize, settings.tile_size())) tile *= 2;
        settings.set_tile_size(tile);
    }
    if (settings.passes_per_unit() == 0)
        settings.set_passes_per_unit(
            defaultPassesPerUnit(settings, size, limits.defaultPassesPerUnit));
    // A unit never spans more passes than the job has (the image does not depend on it).
    settings.set_passes_per_unit(std::min(settings.passes_per_unit(), settings.passes()));
    // A job with a target error decides at 4, 8, 16, ... passes: its pass chunks must end at
    // each of them, so it gets 1, 2 or 4 passes per unit (the most of those not above the
    // setting). More units cost a little more per sample; the image is the same.
    if (settings.has_target_error()) {
        uint32_t perUnit = 1;
        while (perUnit * 2 <= std::min<uint32_t>(4, settings.passes_per_unit())) perUnit *= 2;
        settings.set_passes_per_unit(perUnit);
    }
    if (settings.name().empty()) settings.set_name(fs::path(bundle.scenePath).stem().string());
    const std::optional<RadiusSchedule> radiusSchedule = scene->integrator()->radiusSchedule();
    admitted.filterBorder = filterBorder(*scene);
    admitted.smallerRadius = filmSmallerRadius(*scene);
    scene.reset();
    auto refuse = [&](Kind kind, const std::string& message) {
        removeStaging(admitted.stagingDirectory);
        throw FarmError(kind, message);
    };
    if (uint64_t(size.x()) * uint64_t(size.y()) > limits.maxImagePixels)
        refuse(Kind::ResourceExhausted,
               absl::StrFormat("the image has %dx%d pixels, more than the limit of %u", size.x(),
                               size.y(), limits.maxImagePixels));
    if (settings.passes() > limits.maxPasses)
        refuse(Kind::ResourceExhausted, absl::StrFormat("%u passes requested, the limit is %u",
                                                        settings.passes(), limits.maxPasses));
    if (settings.tile_size() > 16384)
        refuse(Kind::InvalidArgument, "tile size must be at most 16384");
    try {
        admitted.grid = farm::JobGrid(TileGrid(size.x(), size.y(), int(settings.tile_size()),
                                               admitted.filterBorder, admitted.smallerRadius),
                                      settings.passes(), settings.passes_per_unit());
    } catch (const Error& e) {
        refuse(Kind::InvalidArgument, e.what());
    }
    admitted.description.mutable_bundle()->CopyFrom(request.bundle());
    admitted.description.mutable_settings()->CopyFrom(settings);
    if (radiusSchedule) {
        v1::PhotonRadiusSchedule& schedule = *admitted.description.mutable_photon_radius_schedule();
        schedule.set_initial_radius(radiusSchedule->initialRadius);
        schedule.set_alpha(radiusSchedule->alpha);
    }
    // Fields a newer client sent that this coordinator does not know: it cannot check them, and
    // kept in the stored description, they would be serialized at its end here but in field
    // order by a coordinator that knows them, whose start would then find the record's digest
    // (JobStore::recordDigest) changed and fail the job as damaged.
    admitted.description.DiscardUnknownFields();
    return admitted;
}

}  // namespace alphorn::coordinator
