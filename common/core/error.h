// Errors the user can act on. Every message names where the problem is (file, line) and what it
// is; the CLI prints it and exits non-zero, the coordinator returns it to the client.
#pragma once

#include <absl/strings/str_format.h>

#include <stdexcept>
#include <string>

namespace alphorn {

class Error : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

// Input that is well formed but needs more memory than allowed (a scene's geometry beyond the
// limit): the coordinator refuses it with RESOURCE_EXHAUSTED rather than INVALID_ARGUMENT.
class ResourceLimitError : public Error {
  public:
    using Error::Error;
};

template <typename... Args>
[[noreturn]] void fail(const absl::FormatSpec<Args...>& format, const Args&... args) {
    throw Error(absl::StrFormat(format, args...));
}

}  // namespace alphorn
