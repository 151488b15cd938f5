// Fresnel reflectance shared by the dielectric and microfacet BSDFs (Nori's fresnel()).
#pragma once

namespace alphorn {

// Unpolarised Fresnel reflectance of a smooth dielectric interface. cosThetaI is the cosine
// between the incident direction and the normal, which points into the exterior (extIOR) side;
// a negative cosine means the light arrives from the interior, and the indices are swapped.
// Returns 1 under total internal reflection and 0 for index-matched interfaces.
float fresnelDielectric(float cosThetaI, float extIOR, float intIOR);

}  // namespace alphorn
