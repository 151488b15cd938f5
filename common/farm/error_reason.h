// Typed refusals on the wire: a failed call carries an ErrorReason (proto/alphorn/v1/farm.proto)
// in its status details, so programs switch on the reason and people read the message.
#pragma once

#include "alphorn/v1/farm.pb.h"

#include <grpcpp/grpcpp.h>

#include <string>

namespace alphorn::farm {

// A status with `code` and `message` whose details carry `reason`.
grpc::Status statusWithReason(grpc::StatusCode code, const std::string& message,
                              v1::ErrorReason reason);
// The reason a status carries; ERROR_REASON_UNSPECIFIED when it carries none (or details that
// do not parse, e.g. from another kind of server).
v1::ErrorReason reasonOf(const grpc::Status& status);

// True for failures that go away by themselves (the coordinator restarting or unreachable, a
// deadline): the call is worth retrying after a backoff.
bool isTransient(const grpc::Status& status);

}  // namespace alphorn::farm
