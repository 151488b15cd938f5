#include "common/farm/text_field.h"

#include "common/core/error.h"

namespace alphorn::farm {

void checkTextField(const char* what, const std::string& value, size_t maxBytes) {
    if (value.size() > maxBytes)
        fail("%s is %u bytes long; at most %u are allowed", what, value.size(), maxBytes);
    for (size_t i = 0; i < value.size(); ++i) {
        const unsigned char byte = static_cast<unsigned char>(value[i]);
        if (byte < 0x20 || byte == 0x7f)
            fail("%s holds a control character (byte 0x%02x at offset %u)", what, byte, i);
    }
}

}  // namespace alphorn::farm
