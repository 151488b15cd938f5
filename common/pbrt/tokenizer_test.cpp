#include "common/pbrt/tokenizer.h"

#include "common/core/error.h"

#include <gtest/gtest.h>

#include <vector>

namespace alphorn::pbrt {
namespace {

std::vector<Token> tokens(std::string_view text) {
    Tokenizer tokenizer(text, std::make_shared<const std::string>("t.pbrt"));
    std::vector<Token> out;
    Token token;
    while (tokenizer.next(token)) out.push_back(token);
    return out;
}

TEST(PbrtTokenizer, SplitsDirectivesStringsBracketsAndNumbersWithLocations) {
    const std::string text =
        "Shape \"sphere\" # a comment \"not a string\"\n  \"float radius\" [2.5 -1e-3]\n";
    const std::vector<Token> t = tokens(text);
    std::vector<std::string> words;
    for (const Token& token : t) words.emplace_back(token.text);
    EXPECT_EQ(words, (std::vector<std::string>{"Shape", "\"sphere\"", "\"float radius\"", "[",
                                               "2.5", "-1e-3", "]"}));
    EXPECT_EQ(t[0].location.toString(), "t.pbrt:1:1");
    EXPECT_EQ(t[1].location.toString(), "t.pbrt:1:7");
    EXPECT_EQ(t[2].location.toString(), "t.pbrt:2:3");
    EXPECT_EQ(t[4].location.toString(), "t.pbrt:2:19");
    EXPECT_TRUE(t[1].isString());
    EXPECT_EQ(t[1].stringValue(), "sphere");
    EXPECT_FALSE(t[4].isString());
}

TEST(PbrtTokenizer, BracketsNeedNoSpaceAndEscapesAreResolved) {
    const std::vector<Token> t = tokens("[1 2]\"a\\\"b\\\\c\\n\"[\"x\"]");
    ASSERT_EQ(t.size(), 8u);
    EXPECT_EQ(t[0].text, "[");
    EXPECT_EQ(t[2].text, "2");
    EXPECT_EQ(t[3].text, "]");
    EXPECT_EQ(t[4].stringValue(), "a\"b\\c\n");
    EXPECT_EQ(t[5].text, "[");
}

TEST(PbrtTokenizer, RefusesAnUnclosedStringAndNulBytes) {
    try {
        tokens("Shape \"sphere\n\"float radius\" 1");
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("t.pbrt:1:7: a string that is not closed"),
                  std::string::npos)
            << e.what();
    }
    EXPECT_THROW(tokens(std::string_view("Shape \0", 7)), Error);
    EXPECT_THROW(tokens(std::string_view("\"a\0b\"", 5)), Error);
    EXPECT_THROW(tokens("\"ends with a backslash\\"), Error);
}

TEST(PbrtTokenizer, AnEmptyOrCommentOnlyFileHasNoTokens) {
    EXPECT_TRUE(tokens("").empty());
    EXPECT_TRUE(tokens("# nothing\n   \t\r\n# more").empty());
}

}  // namespace
}  // namespace alphorn::pbrt
