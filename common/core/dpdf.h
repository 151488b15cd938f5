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
        m_countSearch = false;
    }
    void reserve(size_t n) { m_cdf.reserve(n + 1); }
    void append(double weight) {
        m_cdf.push_back(m_cdf.back() + weight);
        m_countSearch = false;
    }
    size_t size() const { return m_cdf.size() - 1; }
    // Normalises and returns the sum of the weights (0 when empty or all zero).
    double normalize();
    double sum() const { return m_sum; }
    float operator[](size_t i) const { return static_cast<float>(m_cdf[i + 1] - m_cdf[i]); }
    // Returns an index with probability weight/sum.
    size_t sample(float u) const {
        const double du = static_cast<double>(u);
        // On a short, sorted table the index upper_bound finds is the count of inner bounds at or
        // below u (for u >= 0; NaN and negative u take the search), found without its
        // unpredictable branches: a quad light's table has two entries.
        if (m_countSearch && du >= 0.0) {
            size_t index = 0;
            for (size_t i = 1; i + 1 < m_cdf.size(); ++i) index += m_cdf[i] <= du ? 1 : 0;
            return skipZeroWeights(index);
        }
        return sampleBySearch(u);
    }
    // As sample(), and rescales u to a fresh uniform number for reuse.
    size_t sampleReuse(float& u) const {
        size_t index = sample(u);
        double width = m_cdf[index + 1] - m_cdf[index];
        u = width > 0.0 ? static_cast<float>((u - m_cdf[index]) / width) : 0.0f;
        u = std::min(u, 0.99999994f);
        return index;
    }
    // sample() by binary search alone, whatever the table (what the short tables must match).
    size_t sampleBySearch(float u) const;
    // The most entries sample() counts through instead of searching.
    static constexpr size_t kMaxCountedEntries = 8;

  private:
    // Skips zero-weight entries that the search can land on at exact boundaries.
    size_t skipZeroWeights(size_t index) const {
        while (index + 1 < size() && m_cdf[index + 1] == m_cdf[index]) ++index;
        return index;
    }

    std::vector<double> m_cdf{0.0};
    double m_sum = 0.0;
    bool m_normalized = false;
    // Whether sample() may count: at most kMaxCountedEntries entries, cdf non-decreasing and
    // free of NaN, from 0 (set by normalize()).
    bool m_countSearch = false;
};

}  // namespace alphorn
