// An error with the kind of status the client should see (the services map it to a gRPC code).
#pragma once

#include "common/core/error.h"

namespace alphorn::coordinator {

class FarmError : public Error {
  public:
    enum class Kind { InvalidArgument, NotFound, FailedPrecondition, ResourceExhausted };
    FarmError(Kind kind, const std::string& message) : Error(message), kind(kind) {}
    Kind kind;
};

}  // namespace alphorn::coordinator
