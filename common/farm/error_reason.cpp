#include "common/farm/error_reason.h"

namespace alphorn::farm {

grpc::Status statusWithReason(grpc::StatusCode code, const std::string& message,
                              v1::ErrorReason reason) {
    v1::RpcStatus details;
    details.set_code(static_cast<int32_t>(code));
    details.set_message(message);
    v1::ErrorDetail detail;
    detail.set_reason(reason);
    details.add_details()->PackFrom(detail);
    return {code, message, details.SerializeAsString()};
}

v1::ErrorReason reasonOf(const grpc::Status& status) {
    if (status.ok() || status.error_details().empty()) return v1::ERROR_REASON_UNSPECIFIED;
    v1::RpcStatus details;
    if (!details.ParseFromString(status.error_details())) return v1::ERROR_REASON_UNSPECIFIED;
    for (const auto& any : details.details()) {
        v1::ErrorDetail detail;
        if (any.Is<v1::ErrorDetail>() && any.UnpackTo(&detail)) return detail.reason();
    }
    return v1::ERROR_REASON_UNSPECIFIED;
}

bool isTransient(const grpc::Status& status) {
    switch (status.error_code()) {
        case grpc::StatusCode::UNAVAILABLE:
        case grpc::StatusCode::DEADLINE_EXCEEDED:
        case grpc::StatusCode::CANCELLED:
        case grpc::StatusCode::ABORTED:
            return true;
        default:
            return false;
    }
}

}  // namespace alphorn::farm
