#include "common/medium/medium.h"

namespace alphorn {

void Medium::addChild(const std::shared_ptr<Object>& child, const std::string& name) {
    if (child->kind() != ObjectKind::PhaseFunction) return Object::addChild(child, name);
    if (m_phase) fail("the medium has more than one phase function");
    m_phase = std::static_pointer_cast<PhaseFunction>(child);
}

void Medium::activate() {
    if (!m_phase) {
        PropertyList props(source() + " (default phase)");
        m_phase = std::static_pointer_cast<PhaseFunction>(
            ObjectFactory::create(ObjectKind::PhaseFunction, "isotropic", props));
        m_phase->activate();
    }
}

}  // namespace alphorn
