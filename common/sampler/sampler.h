// Sample generators. A sampler produces the random numbers of one stream (a pixel's camera path
// or a photon's path) in one pass, and its output is a pure function of
// (seed, pass, stream, dimension) -- never of threads, tiles or workers.
#pragma once

#include "common/core/object.h"
#include "common/core/rng.h"

namespace alphorn {

// Every sampler has cache lines of its own (alignas pads the object and its clones' heap blocks):
// a sampler's state is written at every draw, and a clone sharing a line with another thread's
// hot data made two-thread renders up to 1.5x slower, depending on where the heap happened to
// put it (bench/RESULTS.md, "False sharing").
class alignas(128) Sampler : public Object {
  public:
    ObjectKind kind() const override { return ObjectKind::Sampler; }

    virtual std::unique_ptr<Sampler> clone() const = 0;
    // Positions the sampler at the start of a stream; dimensions then advance with each draw.
    virtual void startStream(uint64_t seed, uint64_t pass, uint64_t stream,
                             StreamPurpose purpose) = 0;
    virtual float next1D() = 0;
    virtual Point2f next2D() = 0;

    // Samples per pixel the scene asks for: the default number of passes of a render.
    int sampleCount() const { return m_sampleCount; }

  protected:
    int m_sampleCount = 1;
};

}  // namespace alphorn
