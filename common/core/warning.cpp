#include "common/core/warning.h"

#include <atomic>
#include <iostream>

namespace alphorn {

static std::atomic<WarningSink> g_warningSink{nullptr};

void setWarningSink(WarningSink sink) {
    g_warningSink = sink;
}

void warn(const std::string& message) {
    if (WarningSink sink = g_warningSink) {
        sink(message);
        return;
    }
    std::cerr << "warning: " << message << std::endl;
}

}  // namespace alphorn
