#include "common/stats/test_object.h"

#include <absl/strings/ascii.h>
#include <absl/strings/str_split.h>

#include <cmath>

namespace alphorn {

std::vector<float> parseFloatList(const PropertyList& props, const std::string& name) {
    std::vector<float> values;
    const std::string text = props.getString(name, "");
    for (absl::string_view token :
         absl::StrSplit(text, absl::ByAnyChar(", \t\r\n"), absl::SkipEmpty())) {
        std::string s(token);
        char* end = nullptr;
        const float v = std::strtof(s.c_str(), &end);
        if (*end != '\0') props.fail("%s: could not parse the number \"%s\"", name, s);
        if (!std::isfinite(v)) props.fail("%s: the value \"%s\" is not finite", name, s);
        values.push_back(v);
    }
    return values;
}

}  // namespace alphorn
