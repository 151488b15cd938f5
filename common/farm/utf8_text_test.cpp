#include "common/farm/utf8_text.h"

#include <gtest/gtest.h>

#include <clocale>

namespace alphorn::farm {
namespace {

TEST(Utf8Text, DecodesCharactersAndRefusesInvalidBytes) {
    const std::string text = "a\u00e9\u6f22\U0001f3ac";
    std::vector<std::pair<char32_t, size_t>> decoded;
    for (size_t offset = 0; offset < text.size();) {
        const Utf8Character character = decodeUtf8(text, offset);
        EXPECT_TRUE(character.valid);
        decoded.emplace_back(character.codePoint, character.bytes);
        offset += character.bytes;
    }
    EXPECT_EQ(decoded, (std::vector<std::pair<char32_t, size_t>>{
                           {U'a', 1}, {0xe9, 2}, {0x6f22, 3}, {0x1f3ac, 4}}));
    for (const std::string invalid : {"\x80", "\xc3", "\xc3(", "\xc0\xaf", "\xe0\x80\xaf",
                                      "\xed\xa0\x80", "\xf4\x90\x80\x80", "\xf8\x88\x80\x80\x80"}) {
        const Utf8Character character = decodeUtf8(invalid, 0);
        EXPECT_FALSE(character.valid) << invalid;
        EXPECT_EQ(character.bytes, 1u) << invalid;
    }
}

TEST(Utf8Text, WidthCountsTerminalColumns) {
    EXPECT_EQ(displayWidth(""), 0u);
    EXPECT_EQ(displayWidth("cbox"), 4u);
    EXPECT_EQ(displayWidth("caf\u00e9"), 4u);     // é precomposed
    EXPECT_EQ(displayWidth("cafe\u0301"), 4u);    // e and a combining acute accent
    EXPECT_EQ(displayWidth("\u6f22\u5b57"), 4u);  // 漢字: two wide characters
    EXPECT_EQ(displayWidth("\U0001f3ac"), 2u);    // 🎬
    EXPECT_EQ(displayWidth("a\xff"
                           "b"),
              3u);  // an invalid byte shows as one replacement
}

TEST(Utf8Text, WidthDoesNotDependOnTheProcessLocale) {
    const std::string before = std::setlocale(LC_ALL, nullptr);
    std::setlocale(LC_ALL, "C");
    EXPECT_EQ(displayWidth("\u6f22\u5b57 cafe\u0301 \U0001f3ac"), 4u + 1 + 4 + 1 + 2);
    std::setlocale(LC_ALL, before.c_str());
}

TEST(Utf8Text, FitPadsAndCutsByColumns) {
    EXPECT_EQ(fitToColumns("ab", 4), "ab  ");
    EXPECT_EQ(fitToColumns("\u6f22\u5b57", 6), "\u6f22\u5b57  ");
    EXPECT_EQ(fitToColumns("\u6f22\u5b57\u6f22\u5b57", 5), "\u6f22\u5b57\u2026");
    // A wide character that would end past the ellipsis is left out whole, and a space fills.
    EXPECT_EQ(fitToColumns("\u6f22\u5b57\u6f22\u5b57", 4), "\u6f22\u2026 ");
    // A combining mark stays with its letter.
    EXPECT_EQ(fitToColumns("e\u0301e\u0301e\u0301", 2), "e\u0301\u2026");
    EXPECT_EQ(fitToColumns("abc", 0), "");
    EXPECT_EQ(displayWidth(fitToColumns("cafe\u0301 \U0001f3ac \u6f22\u5b57 long name", 9)), 9u);
}

}  // namespace
}  // namespace alphorn::farm
