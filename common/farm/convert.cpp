#include "common/farm/convert.h"

#include <google/protobuf/util/json_util.h>

namespace alphorn::farm {

v1::BundleManifest toProto(const Bundle& bundle) {
    v1::BundleManifest manifest;
    manifest.set_scene_path(bundle.scenePath);
    for (const BundleEntry& entry : bundle.files) {
        v1::BundleFile* file = manifest.add_files();
        file->set_path(entry.path);
        file->set_sha256(entry.sha256);
        file->set_size(entry.size);
    }
    return manifest;
}

Bundle fromProto(const v1::BundleManifest& manifest) {
    Bundle bundle;
    bundle.scenePath = manifest.scene_path();
    for (const v1::BundleFile& file : manifest.files())
        bundle.files.push_back(BundleEntry{file.path(), file.sha256(), file.size(), ""});
    return bundle;
}

v1::UnitSpec toProto(uint64_t jobId, uint32_t unitIndex, const RenderUnit& unit) {
    v1::UnitSpec spec;
    spec.set_job_id(jobId);
    spec.set_unit_index(unitIndex);
    spec.set_pass_begin(unit.passBegin);
    spec.set_pass_end(unit.passEnd);
    spec.set_x0(unit.tile.x0);
    spec.set_y0(unit.tile.y0);
    spec.set_x1(unit.tile.x1);
    spec.set_y1(unit.tile.y1);
    return spec;
}

RenderUnit fromProto(const v1::UnitSpec& spec) {
    RenderUnit unit;
    unit.passBegin = spec.pass_begin();
    unit.passEnd = spec.pass_end();
    unit.tile = Tile{spec.x0(), spec.y0(), spec.x1(), spec.y1()};
    return unit;
}

const char* jobStateName(v1::JobState state) {
    switch (state) {
        case v1::JOB_STATE_RUNNING:
            return "running";
        case v1::JOB_STATE_DONE:
            return "done";
        case v1::JOB_STATE_FAILED:
            return "failed";
        case v1::JOB_STATE_CANCELLED:
            return "cancelled";
        default:
            return "unknown";
    }
}

std::string toJson(const google::protobuf::Message& message) {
    std::string json;
    google::protobuf::util::JsonPrintOptions options;
    options.always_print_primitive_fields = true;
    options.preserve_proto_field_names = true;
    (void)google::protobuf::util::MessageToJsonString(message, &json, options);
    return json;
}

}  // namespace alphorn::farm
