// Loading a job's scene the same way on the coordinator (validation at submit) and on workers
// (rendering), so both see the same integrator, image size and pass count.
#pragma once

#include <memory>
#include <string>

namespace alphorn {
class Scene;
}

namespace alphorn::farm {

// Loads the scene; with a nonempty `integratorOverride`, replaces the scene's integrator by a
// default-constructed one of that XML type. Throws the loader's Error ("file:line: problem").
std::shared_ptr<Scene> loadJobScene(const std::string& scenePath,
                                    const std::string& integratorOverride);

}  // namespace alphorn::farm
