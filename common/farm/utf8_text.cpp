#include "common/farm/utf8_text.h"

#include <locale.h>
#include <clocale>
#include <cwchar>

namespace alphorn::farm {

namespace {

bool isContinuation(unsigned char byte) {
    return (byte & 0xc0) == 0x80;
}

// The C.UTF-8 locale's character classes, made once; null where the C library has none.
locale_t utf8Locale() {
    static const locale_t locale = newlocale(LC_CTYPE_MASK, "C.UTF-8", locale_t(nullptr));
    return locale;
}

int columnsOf(char32_t codePoint) {
    const locale_t locale = utf8Locale();
    if (!locale) return 1;
    const locale_t previous = uselocale(locale);
    const int width = wcwidth(static_cast<wchar_t>(codePoint));
    uselocale(previous);
    return width < 0 ? 1 : width;
}

}  // namespace

Utf8Character decodeUtf8(std::string_view text, size_t offset) {
    const auto byteAt = [&](size_t i) { return static_cast<unsigned char>(text[offset + i]); };
    const unsigned char lead = byteAt(0);
    if (lead < 0x80) return {lead, 1, true};
    size_t length = 0;
    char32_t codePoint = 0;
    // The smallest and largest second byte the lead allows (excluding overlong forms,
    // surrogates and code points past U+10FFFF, as RFC 3629 does).
    unsigned char low = 0x80, high = 0xbf;
    if (lead >= 0xc2 && lead <= 0xdf) {
        length = 2;
        codePoint = lead & 0x1f;
    } else if (lead >= 0xe0 && lead <= 0xef) {
        length = 3;
        codePoint = lead & 0x0f;
        if (lead == 0xe0) low = 0xa0;
        if (lead == 0xed) high = 0x9f;
    } else if (lead >= 0xf0 && lead <= 0xf4) {
        length = 4;
        codePoint = lead & 0x07;
        if (lead == 0xf0) low = 0x90;
        if (lead == 0xf4) high = 0x8f;
    } else {
        return {lead, 1, false};
    }
    if (offset + length > text.size()) return {lead, 1, false};
    if (byteAt(1) < low || byteAt(1) > high) return {lead, 1, false};
    for (size_t i = 1; i < length; ++i) {
        if (!isContinuation(byteAt(i))) return {lead, 1, false};
        codePoint = (codePoint << 6) | (byteAt(i) & 0x3f);
    }
    return {codePoint, length, true};
}

size_t displayWidth(std::string_view text) {
    size_t columns = 0;
    for (size_t offset = 0; offset < text.size();) {
        const Utf8Character character = decodeUtf8(text, offset);
        columns += character.valid ? columnsOf(character.codePoint) : 1;
        offset += character.bytes;
    }
    return columns;
}

std::string fitToColumns(std::string_view text, size_t columns) {
    size_t width = displayWidth(text);
    std::string fitted;
    if (width <= columns) {
        fitted = text;
    } else {
        // Whole characters while they leave a column for the ellipsis; the zero-width ones
        // after the last kept character (its combining marks) stay with it.
        width = 0;
        size_t offset = 0;
        while (offset < text.size()) {
            const Utf8Character character = decodeUtf8(text, offset);
            const size_t characterWidth = character.valid ? columnsOf(character.codePoint) : 1;
            if (columns == 0 || width + characterWidth > columns - 1) break;
            width += characterWidth;
            offset += character.bytes;
        }
        fitted = text.substr(0, offset);
        if (columns > 0) {
            fitted += "…";
            ++width;
        }
    }
    return fitted + std::string(columns - width, ' ');
}

}  // namespace alphorn::farm
