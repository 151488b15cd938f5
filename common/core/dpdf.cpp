#include "common/core/dpdf.h"

namespace alphorn {

double DiscretePDF::normalize() {
    m_sum = m_cdf.back();
    if (m_sum > 0.0) {
        double inv = 1.0 / m_sum;
        for (double& c : m_cdf) c *= inv;
        m_cdf.back() = 1.0;
    }
    m_normalized = true;
    m_countSearch = size() >= 1 && size() <= kMaxCountedEntries && m_cdf[0] == 0.0;
    for (size_t i = 1; i < m_cdf.size(); ++i)
        if (!(m_cdf[i] >= m_cdf[i - 1])) m_countSearch = false;  // also catches NaN
    return m_sum;
}

size_t DiscretePDF::sampleBySearch(float u) const {
    auto it = std::upper_bound(m_cdf.begin(), m_cdf.end(), static_cast<double>(u));
    size_t index = static_cast<size_t>(std::max<std::ptrdiff_t>(0, it - m_cdf.begin() - 1));
    index = std::min(index, size() - 1);
    return skipZeroWeights(index);
}

}  // namespace alphorn
