#include "common/core/transform.h"

#include <sstream>

namespace alphorn {

std::string Transform::toString() const {
    std::ostringstream out;
    out << m_transform.format(Eigen::IOFormat(4, 0, ", ", ";\n", "", "", "[", "]"));
    return out.str();
}

}  // namespace alphorn
