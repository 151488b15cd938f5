// An error with the kind of status the client should see (the services map it to a gRPC code).
#pragma once

#include "common/core/error.h"

namespace alphorn::coordinator {

class FarmError : public Error {
  public:
    // UnknownWorker: a worker id the coordinator does not know (the worker registers again).
    // Unavailable: the call may succeed when asked again. CallerGone: the caller went away
    // (deadline, cancel, lost connection) before anything was done for it.
    enum class Kind {
        InvalidArgument,
        NotFound,
        FailedPrecondition,
        ResourceExhausted,
        UnknownWorker,
        Unavailable,
        CallerGone
    };
    FarmError(Kind kind, const std::string& message) : Error(message), kind(kind) {}
    Kind kind;
};

}  // namespace alphorn::coordinator
