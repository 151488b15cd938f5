// Warnings: problems a user should hear about that do not stop the work (a scene property no
// plugin read, a scene without an emitter). The CLI prints each on stderr as "warning: ...";
// the farm daemons log each as an event instead (farm::routeLibraryOutputToLog), since their
// stderr is their log, whose lines text from a scene must not be able to forge.
#pragma once

#include <absl/strings/str_format.h>

#include <string>

namespace alphorn {

// Where warnings go: a function that takes each message (without a "warning: " prefix).
using WarningSink = void (*)(const std::string& message);
// Null restores the default, stderr.
void setWarningSink(WarningSink sink);

void warn(const std::string& message);

template <typename... Args>
void warn(const absl::FormatSpec<Args...>& format, const Args&... args) {
    warn(absl::StrFormat(format, args...));
}

}  // namespace alphorn
