// Equiangular sampling (Kulla and Fajardo, "Importance Sampling Techniques for Path Tracing
// in Participating Media", 2012) on one segment of a path through a medium.
//
// Free-flight sampling puts scattering points where the medium is dense, not where a light is
// near: in fog under a spotlight the few next-event estimates taken close to the light carry
// huge 1/d² weights (fireflies). Equiangular sampling draws a point on the segment with density
// proportional to 1/(D² + (t − Δ)²) towards a chosen point-like light (uniform in the angle the
// segment subtends at the light), which cancels the 1/d². The two are combined per light by
// the balance heuristic; free-flight sampling remains the one that continues the path. Used in
// grey homogeneous media, whose free-flight density σt e^(−σt t) is known in closed form.
//
// The estimate that combines the two, sampleEquiangular(), is in common/integrator/volume.cpp.
#pragma once

#include "common/core/common.h"

#include <cmath>

namespace alphorn {

// A segment of a path through one medium: t in [0, end] from `origin` along unit `direction`.
struct EquiangularSegment {
    Point3f origin;
    Vector3f direction;
    float end;
    float sigmaT;  // the medium's grey extinction
};

// A light as seen from a segment: Δ, the parameter of the point closest to it, its distance D
// from the line, and the angles at the light of the segment's two ends.
struct EquiangularFrame {
    float delta, distance, thetaA, thetaB;
    bool valid;  // false for a light on the line: free-flight sampling alone then
};

EquiangularFrame equiangularFrame(const EquiangularSegment& segment, const Point3f& light);

inline float equiangularPdf(const EquiangularFrame& frame, float t) {
    if (!frame.valid) return 0.0f;
    const float x = t - frame.delta;
    return frame.distance /
           ((frame.thetaB - frame.thetaA) * (frame.distance * frame.distance + x * x));
}

// The density with which free-flight sampling scatters at t on the segment.
inline float freeFlightPdf(const EquiangularSegment& segment, float t) {
    return segment.sigmaT * std::exp(-segment.sigmaT * t);
}

}  // namespace alphorn
