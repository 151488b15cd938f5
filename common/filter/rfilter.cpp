#include "common/filter/rfilter.h"

namespace alphorn {

// The renderer splats into a fixed-size table of at most 16 pixels per axis.
float ReconstructionFilter::validatedRadius(const PropertyList& props, float defaultRadius) {
    float radius = props.getPositiveFloat("radius", defaultRadius);
    if (radius > 7.0f) props.fail("filter radius %g is too large (at most 7 pixels)", radius);
    return radius;
}

}  // namespace alphorn
