// Conversions between the wire messages (alphorn.v1) and the engine's types.
#pragma once

#include "alphorn/v1/farm.pb.h"
#include "common/farm/bundle.h"
#include "common/render/unit.h"

#include <string>

namespace alphorn::farm {

v1::BundleManifest toProto(const Bundle& bundle);
Bundle fromProto(const v1::BundleManifest& manifest);

v1::UnitSpec toProto(uint64_t jobId, uint32_t unitIndex, const RenderUnit& unit);
RenderUnit fromProto(const v1::UnitSpec& spec);

const char* jobStateName(v1::JobState state);

// A message as JSON with every field, zero ones included, under its proto field name: what
// `alphorn ... --json` prints and the dashboard's API answers.
std::string toJson(const google::protobuf::Message& message);

}  // namespace alphorn::farm
