// Warps from the unit square to other domains, each with its density (Nori's Warp). Every warp
// has a chi-square test in warp_test.cpp.
#pragma once

#include "common/core/common.h"

namespace alphorn::warp {

Point2f squareToUniformSquare(const Point2f& sample);
float squareToUniformSquarePdf(const Point2f& p);

// Tent on [-1, 1]^2 (separable).
Point2f squareToTent(const Point2f& sample);
float squareToTentPdf(const Point2f& p);

// Unit disk, by the concentric map (Shirley-Chiu): no clumping at the centre.
Point2f squareToUniformDisk(const Point2f& sample);
float squareToUniformDiskPdf(const Point2f& p);

// Barycentrics (u, v) uniform over a triangle.
Point2f squareToUniformTriangle(const Point2f& sample);

Vector3f squareToUniformSphere(const Point2f& sample);
float squareToUniformSpherePdf(const Vector3f& v);

Vector3f squareToUniformHemisphere(const Point2f& sample);
float squareToUniformHemispherePdf(const Vector3f& v);

// Uniform over the cap of directions with cos(theta) >= cosThetaMax around +z.
Vector3f squareToUniformSphereCap(const Point2f& sample, float cosThetaMax);
float squareToUniformSphereCapPdf(const Vector3f& v, float cosThetaMax);

Vector3f squareToCosineHemisphere(const Point2f& sample);
float squareToCosineHemispherePdf(const Vector3f& v);

// Beckmann distribution of microfacet normals, sampled in proportion to D(m) cos(theta_m).
Vector3f squareToBeckmann(const Point2f& sample, float alpha);
float squareToBeckmannPdf(const Vector3f& m, float alpha);

}  // namespace alphorn::warp
