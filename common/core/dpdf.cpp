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
    return m_sum;
}

size_t DiscretePDF::sample(float u) const {
    auto it = std::upper_bound(m_cdf.begin(), m_cdf.end(), static_cast<double>(u));
    size_t index = static_cast<size_t>(std::max<std::ptrdiff_t>(0, it - m_cdf.begin() - 1));
    index = std::min(index, size() - 1);
    // Skip zero-weight entries that upper_bound can land on at exact boundaries.
    while (index + 1 < size() && m_cdf[index + 1] == m_cdf[index]) ++index;
    return index;
}

size_t DiscretePDF::sampleReuse(float& u) const {
    size_t index = sample(u);
    double width = m_cdf[index + 1] - m_cdf[index];
    u = width > 0.0 ? static_cast<float>((u - m_cdf[index]) / width) : 0.0f;
    u = std::min(u, 0.99999994f);
    return index;
}

}  // namespace alphorn
