// Reading UTF-8 text from clients byte by byte, the same way wherever it is shown: the log
// formatter (log.h) decides per character what to escape, and the CLI's tables pad names by the
// columns a terminal gives them, not by their bytes.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace alphorn::farm {

// One character of UTF-8 text: its code point and its bytes. A byte that does not start a
// valid sequence (a stray continuation byte, an overlong form, a surrogate, a code point past
// U+10FFFF, a sequence cut short) is one invalid character of one byte.
struct Utf8Character {
    char32_t codePoint = 0;
    size_t bytes = 1;
    bool valid = false;
};
// The character that starts at text[offset] (offset < text.size()). Independent of the locale.
Utf8Character decodeUtf8(std::string_view text, size_t offset);

// The columns a terminal gives `text`: wide characters (CJK, most emoji) take two, combining
// marks and other zero-width characters none, everything else one; an invalid byte or a
// control character takes one (a terminal shows a replacement for it, or the table was wrong
// anyway). Character widths are the C library's wcwidth() for its built-in C.UTF-8 locale,
// whatever the process's own locale, so the result does not depend on LANG. Sequences that
// terminals draw as one glyph (emoji joined by U+200D, flags) are counted per character.
size_t displayWidth(std::string_view text);

// `text` padded with spaces to `columns` columns; text wider than that is cut at a character
// boundary and ends with "…" within the columns (a combining mark stays with its letter).
std::string fitToColumns(std::string_view text, size_t columns);

}  // namespace alphorn::farm
