#include "common/farm/text_field.h"

#include "common/core/error.h"

#include <gtest/gtest.h>

namespace alphorn::farm {
namespace {

std::string refusal(const std::string& value) {
    try {
        checkTextField("the job's name", value);
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

TEST(TextField, PrintableTextUpToTheLimitIsAccepted) {
    EXPECT_EQ(refusal(""), "");
    EXPECT_EQ(refusal("cbox 512² (final) — v2"), "");
    EXPECT_EQ(refusal(std::string(kMaxTextFieldBytes, 'x')), "");
}

TEST(TextField, LongTextIsRefusedWithItsLength) {
    const std::string message = refusal(std::string(kMaxTextFieldBytes + 1, 'x'));
    EXPECT_NE(message.find("the job's name is 257 bytes long; at most 256"), std::string::npos)
        << message;
}

TEST(TextField, ControlCharactersAreRefusedWithTheirPlace) {
    for (const char control : {'\0', '\n', '\r', '\x1b', '\x07', '\x7f'}) {
        const std::string message = refusal(std::string("ab") + control + "c");
        EXPECT_NE(message.find("control character"), std::string::npos) << int(control);
        EXPECT_NE(message.find("at offset 2"), std::string::npos) << message;
    }
}

}  // namespace
}  // namespace alphorn::farm
