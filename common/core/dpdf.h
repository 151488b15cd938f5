// A discrete distribution built from non-negative weights (Nori's DiscretePDF), sampled by
// inverting its cumulative sum.
#pragma once

#include "common/core/common.h"

namespace alphorn {

class DiscretePDF {
  public:
    void clear() {
        m_cdf.assign(1, 0.0);
        m_normalized = false;
    }
    void reserve(size_t n) { m_cdf.reserve(n + 1); }
    void append(double weight) { m_cdf.push_back(m_cdf.back() + weight); }
    size_t size() const { return m_cdf.size() - 1; }
    // Normalises and returns the sum of the weights (0 when empty or all zero).
    double normalize();
    double sum() const { return m_sum; }
    float operator[](size_t i) const { return static_cast<float>(m_cdf[i + 1] - m_cdf[i]); }
    // Returns an index with probability weight/sum.
    size_t sample(float u) const;
    // As sample(), and rescales u to a fresh uniform number for reuse.
    size_t sampleReuse(float& u) const;

  private:
    std::vector<double> m_cdf{0.0};
    double m_sum = 0.0;
    bool m_normalized = false;
};

}  // namespace alphorn
