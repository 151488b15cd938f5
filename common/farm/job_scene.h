// Loading a job's scene the same way on the coordinator (validation at submit) and on workers
// (rendering), so both see the same integrator, image size and pass count.
#pragma once

#include "common/scene/parser.h"

#include <memory>
#include <string>

namespace alphorn {
class Scene;
}

namespace alphorn::farm {

// Loads the scene of a job's bundle materialized in `bundleDirectory` (`scenePath` lies inside
// it). Every file the scene names must lie inside the bundle: an absolute path, a ".." past its
// root or a symbolic link leading out is refused, so a job cannot read the server's own files.
// With a nonempty `integratorOverride`, replaces the scene's integrator by a default-constructed
// one of that XML type. Throws the loader's Error ("file:line: problem"), which names files by
// their paths in the bundle and never shows where the bundle lies on the server; a scene beyond
// `limits` throws ResourceLimitError before any mesh is built, and every other refusal of what
// asks for more memory or size than allowed is a ResourceLimitError too. The coordinator loads
// with SceneUse::Check (everything but the acceleration structure), workers to render.
std::shared_ptr<Scene> loadJobScene(const std::string& bundleDirectory,
                                    const std::string& scenePath,
                                    const std::string& integratorOverride,
                                    const SceneLimits& limits = {},
                                    SceneUse use = SceneUse::Render);

// The same for a scene on disk, which may name any file (benchmarks comparing integrators).
std::shared_ptr<Scene> loadSceneWithIntegrator(const std::string& scenePath,
                                               const std::string& integratorOverride);

}  // namespace alphorn::farm
