#include "common/filter/rfilter.h"

namespace alphorn {

// The renderer splats into a fixed-size table of at most 16 pixels per axis. A sample lies up to
// half a pixel from the centre of the pixel it falls in (along each axis): a smaller radius
// reaches no centre from some samples, and from nearly all as the radius shrinks (a radius of
// 1e-30 rendered a black image).
float ReconstructionFilter::validatedRadius(const PropertyList& props, float defaultRadius) {
    float radius = props.getPositiveFloat("radius", defaultRadius);
    if (radius < kMinRadius)
        props.fail(
            "filter radius %g is too small (at least %g pixels, so that every sample reaches the "
            "centre of the pixel it lies in)",
            radius, kMinRadius);
    if (radius > kMaxRadius)
        props.fail("filter radius %g is too large (at most %g pixels)", radius, kMaxRadius);
    return radius;
}

void ReconstructionFilter::tabulate() {
    m_binsPerUnit = static_cast<float>(kTableSize) / m_radius;
    for (int i = 0; i < kTableSize; ++i)
        m_table[i] =
            eval((static_cast<float>(i) + 0.5f) * m_radius / static_cast<float>(kTableSize));
}

}  // namespace alphorn
