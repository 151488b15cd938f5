#include "common/camera/camera.h"

#include "common/medium/medium.h"

namespace alphorn {

void Camera::addChild(const std::shared_ptr<Object>& child, const std::string& name) {
    if (child->kind() == ObjectKind::Medium) {
        if (m_medium) fail("the camera has more than one medium");
        m_medium = std::static_pointer_cast<Medium>(child);
        return;
    }
    if (child->kind() != ObjectKind::Filter) return Object::addChild(child, name);
    if (m_filter) fail("the camera has more than one reconstruction filter");
    m_filter = std::static_pointer_cast<ReconstructionFilter>(child);
}

void Camera::activate() {
    if (!m_filter) {
        // Nori's default: a gaussian of radius 2 and standard deviation 0.5.
        PropertyList props(source() + " (default rfilter)");
        m_filter = std::static_pointer_cast<ReconstructionFilter>(
            ObjectFactory::create(ObjectKind::Filter, "gaussian", props));
        m_filter->activate();
    }
}

}  // namespace alphorn
