// Fresnel reflectance shared by the dielectric, conductor, microfacet and coated BSDFs.
#pragma once

#include "common/core/color.h"

namespace alphorn {

// Unpolarised Fresnel reflectance of a smooth dielectric interface. cosThetaI is the cosine
// between the incident direction and the normal, which points into the exterior (extIOR) side;
// a negative cosine means the light arrives from the interior, and the indices are swapped.
// Returns 1 under total internal reflection and 0 for index-matched interfaces.
float fresnelDielectric(float cosThetaI, float extIOR, float intIOR);

// Unpolarised Fresnel reflectance of a smooth conductor of complex index eta + i k met from a
// dielectric of index 1 (for another outside index, divide eta and k by it), for each colour
// channel. cosThetaI is clamped to [0, 1]; the surface is the same from both sides. eta = 1,
// k = 0 reflects nothing; k -> infinity reflects everything.
Color3f fresnelConductor(float cosThetaI, const Color3f& eta, const Color3f& k);

}  // namespace alphorn
