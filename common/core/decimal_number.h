// The one number syntax scene files and OBJ files are checked against. C's strtof also reads
// hexadecimal ("0x10" as 16), "nan(...)" and "infinity"; tinyobjloader reads a prefix of a token
// and makes anything else 0. Both are given only what this accepts.
#pragma once

#include <string_view>

namespace alphorn {

// Whether `s` is, in full, a decimal number: an optional sign, digits with an optional decimal
// point (at least one digit, before or after the point), and an optional exponent: e or E, an
// optional sign and at least one digit. "16", "-.5", "5.", "1.6e+1"; not "0x10", "1e", ".", "inf".
inline bool isDecimalNumber(std::string_view s) {
    auto isDigit = [](char c) { return c >= '0' && c <= '9'; };
    size_t i = 0;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
    size_t digits = 0;
    for (; i < s.size() && isDigit(s[i]); ++i) ++digits;
    if (i < s.size() && s[i] == '.')
        for (++i; i < s.size() && isDigit(s[i]); ++i) ++digits;
    if (digits == 0) return false;
    if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
        ++i;
        if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
        size_t exponentDigits = 0;
        for (; i < s.size() && isDigit(s[i]); ++i) ++exponentDigits;
        if (exponentDigits == 0) return false;
    }
    return i == s.size();
}

}  // namespace alphorn
