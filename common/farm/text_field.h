// Free text a client or worker sends (a job's name and owner, a worker's name): it is stored,
// logged, listed in terminals and exported as metrics labels, so it is bounded in length and
// holds no control characters (which would forge log lines or move a terminal's cursor).
#pragma once

#include <cstddef>
#include <string>

namespace alphorn::farm {

inline constexpr size_t kMaxTextFieldBytes = 256;

// Throws Error naming `what` when `value` is longer than `maxBytes` or holds a byte below 0x20
// or 0x7f (bytes from 0x80 on, UTF-8's multibyte characters, are allowed).
void checkTextField(const char* what, const std::string& value,
                    size_t maxBytes = kMaxTextFieldBytes);

}  // namespace alphorn::farm
