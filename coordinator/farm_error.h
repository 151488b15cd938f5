// An error with the kind of status the client should see (the services map it to a gRPC code).
#pragma once

#include "common/core/error.h"

namespace alphorn::coordinator {

class FarmError : public Error {
  public:
    // UnknownWorker: a worker id the coordinator does not know (the worker registers again).
    enum class Kind {
        InvalidArgument,
        NotFound,
        FailedPrecondition,
        ResourceExhausted,
        UnknownWorker
    };
    FarmError(Kind kind, const std::string& message) : Error(message), kind(kind) {}
    Kind kind;
};

}  // namespace alphorn::coordinator
