// The coordinator logs with the farm's structured logger (common/farm/log.h), shared with the
// worker so both daemons write the same key=value lines.
#pragma once

#include "common/farm/log.h"

namespace alphorn::coordinator {

using farm::field;
using farm::logError;
using farm::LogField;
using farm::logInfo;
using farm::LogSink;
using farm::logWarning;
using farm::setLogSink;

}  // namespace alphorn::coordinator
