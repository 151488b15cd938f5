#include "common/medium/equiangular.h"

namespace alphorn {

EquiangularFrame equiangularFrame(const EquiangularSegment& segment, const Point3f& light) {
    EquiangularFrame frame;
    const Vector3f toLight = light - segment.origin;
    frame.delta = toLight.dot(segment.direction);
    frame.distance = (toLight - frame.delta * segment.direction).norm();
    frame.thetaA = std::atan2(-frame.delta, frame.distance);
    frame.thetaB = std::atan2(segment.end - frame.delta, frame.distance);
    frame.valid =
        frame.distance > 1e-6f * (std::abs(frame.delta) + 1.0f) && frame.thetaB > frame.thetaA;
    return frame;
}

}  // namespace alphorn
