#include "common/core/warp.h"

namespace alphorn::warp {

Point2f squareToUniformSquare(const Point2f& sample) {
    return sample;
}

float squareToUniformSquarePdf(const Point2f& p) {
    return (p.array() >= 0).all() && (p.array() <= 1).all() ? 1.0f : 0.0f;
}

static float tent1D(float u) {
    return u < 0.5f ? std::sqrt(2.0f * u) - 1.0f : 1.0f - std::sqrt(2.0f - 2.0f * u);
}

Point2f squareToTent(const Point2f& sample) {
    return Point2f(tent1D(sample.x()), tent1D(sample.y()));
}

float squareToTentPdf(const Point2f& p) {
    auto tent = [](float x) { return std::max(0.0f, 1.0f - std::abs(x)); };
    return tent(p.x()) * tent(p.y());
}

Point2f squareToUniformDisk(const Point2f& sample) {
    float a = 2.0f * sample.x() - 1.0f, b = 2.0f * sample.y() - 1.0f;
    if (a == 0.0f && b == 0.0f) return Point2f(0.0f, 0.0f);
    float r, phi;
    if (a * a > b * b) {
        r = a;
        phi = (Pi / 4.0f) * (b / a);
    } else {
        r = b;
        phi = (Pi / 2.0f) - (Pi / 4.0f) * (a / b);
    }
    return Point2f(r * std::cos(phi), r * std::sin(phi));
}

float squareToUniformDiskPdf(const Point2f& p) {
    return p.squaredNorm() <= 1.0f ? InvPi : 0.0f;
}

Point2f squareToUniformTriangle(const Point2f& sample) {
    float su = std::sqrt(sample.x());
    return Point2f(1.0f - su, sample.y() * su);
}

Vector3f squareToUniformSphere(const Point2f& sample) {
    float z = 1.0f - 2.0f * sample.x();
    float r = safeSqrt(1.0f - z * z);
    float phi = 2.0f * Pi * sample.y();
    return Vector3f(r * std::cos(phi), r * std::sin(phi), z);
}

float squareToUniformSpherePdf(const Vector3f&) {
    return Inv4Pi;
}

Vector3f squareToUniformHemisphere(const Point2f& sample) {
    float z = sample.x();
    float r = safeSqrt(1.0f - z * z);
    float phi = 2.0f * Pi * sample.y();
    return Vector3f(r * std::cos(phi), r * std::sin(phi), z);
}

float squareToUniformHemispherePdf(const Vector3f& v) {
    return v.z() >= 0.0f ? Inv2Pi : 0.0f;
}

Vector3f squareToUniformSphereCap(const Point2f& sample, float cosThetaMax) {
    float z = 1.0f - sample.x() * (1.0f - cosThetaMax);
    float r = safeSqrt(1.0f - z * z);
    float phi = 2.0f * Pi * sample.y();
    return Vector3f(r * std::cos(phi), r * std::sin(phi), z);
}

float squareToUniformSphereCapPdf(const Vector3f& v, float cosThetaMax) {
    if (v.z() < cosThetaMax) return 0.0f;
    return 1.0f / (2.0f * Pi * (1.0f - cosThetaMax));
}

Vector3f squareToCosineHemisphere(const Point2f& sample) {
    Point2f d = squareToUniformDisk(sample);
    float z = safeSqrt(1.0f - d.squaredNorm());
    return Vector3f(d.x(), d.y(), z);
}

float squareToCosineHemispherePdf(const Vector3f& v) {
    return v.z() > 0.0f ? v.z() * InvPi : 0.0f;
}

Vector3f squareToBeckmann(const Point2f& sample, float alpha) {
    float phi = 2.0f * Pi * sample.y();
    // tan^2(theta) = -alpha^2 log(1 - u); 1 - u keeps the log finite for u in [0, 1).
    float tan2Theta = -alpha * alpha * std::log(1.0f - sample.x());
    float cosTheta = 1.0f / std::sqrt(1.0f + tan2Theta);
    float sinTheta = safeSqrt(1.0f - cosTheta * cosTheta);
    return Vector3f(sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta);
}

float squareToBeckmannPdf(const Vector3f& m, float alpha) {
    if (m.z() <= 0.0f) return 0.0f;
    float cosTheta2 = m.z() * m.z();
    float tan2Theta = (1.0f - cosTheta2) / cosTheta2;
    float cosTheta3 = cosTheta2 * m.z();
    float alpha2 = alpha * alpha;
    return std::exp(-tan2Theta / alpha2) / (Pi * alpha2 * cosTheta3);
}

}  // namespace alphorn::warp
