#!/usr/bin/python3
"""Checks the include graph against the layer order of docs/architecture.md ("Layers").

Every source file of the engine (common/) and of the programs built on it (cli/, coordinator/,
worker/) belongs to one layer; a file may include headers of its own layer and of lower layers,
never of a higher one. A few files sit in another layer than their folder (FILE_LAYERS, each
with the reason). Unit tests (*_test.cpp) and their helpers (*_testing.h) may include anything:
a test of a texture may load a scene to build one. A helper is for tests only, so any other file
including one is an error too.

Usage: check-layers.py [REPOSITORY]   (default: the repository this script is in)
Prints each violation as FILE:LINE: problem and exits 1 when there is any.
"""

import pathlib
import re
import sys

# Lowest first. A folder, or a file named in FILE_LAYERS, is in exactly one layer.
LAYERS = [
    ("core", ["common/core"]),
    ("samplers and statistics", ["common/sampler", "common/stats"]),
    ("textures, filters and phase functions", ["common/texture", "common/filter", "common/phase"]),
    ("materials and media", ["common/bsdf", "common/medium"]),
    ("lights and cameras", ["common/emitter", "common/camera"]),
    ("scene", ["common/scene", "common/pbrt"]),
    ("photon maps", ["common/photon"]),
    ("integrators", ["common/integrator"]),
    ("rendering", ["common/render"]),
    ("farm", ["common/farm"]),
    ("programs", ["cli", "coordinator", "worker"]),
]

# Files whose layer is not their folder's, and why.
FILE_LAYERS = {
    # The mesh's geometry and the Intersection record depend only on core; area lights sample
    # the mesh they sit on. (mesh.cpp, which attaches BSDF, emitter and media, is in scene.)
    "common/scene/mesh.h": "materials and media",
    # The exact film depends only on core and the filters; integrators splat light paths into
    # it (Integrator::addPassSplats), so it sits below them.
    "common/render/film.h": "lights and cameras",
    "common/render/film.cpp": "lights and cameras",
    # The interface every integrator implements depends only on core; the scene holds one.
    "common/integrator/integrator.h": "scene",
    # The statistical test plugins: <chi2test> samples BSDFs and phase functions, <ttest>
    # loads scenes and runs their integrators.
    "common/stats/chi2test.cpp": "materials and media",
    "common/stats/ttest.cpp": "integrators",
}

SOURCE_SUFFIXES = (".h", ".cpp")
INCLUDE = re.compile(r'^\s*#\s*include\s*"([^"]+)"')


def is_test_file(path):
    return path.endswith("_test.cpp") or path.endswith("_testing.h")


def layer_index(path, by_name, by_folder):
    """The layer of a repository-relative path, or None for paths outside every layer."""
    if path in FILE_LAYERS:
        return by_name[FILE_LAYERS[path]]
    folder = path
    while "/" in folder:
        folder = folder.rsplit("/", 1)[0]
        if folder in by_folder:
            return by_folder[folder]
    return None


def check(root):
    by_name = {name: i for i, (name, _) in enumerate(LAYERS)}
    by_folder = {folder: i for i, (_, folders) in enumerate(LAYERS) for folder in folders}
    problems = []
    for path in sorted(FILE_LAYERS):
        if not (root / path).is_file():
            problems.append(f"{path}: named in FILE_LAYERS but does not exist")
    for folder in sorted((root / "common").iterdir()):
        name = folder.relative_to(root).as_posix()
        if folder.is_dir() and name not in by_folder:
            problems.append(f"{name}: a folder in no layer (add it to LAYERS and the docs)")
    checked = 0
    for folder in sorted(by_folder):
        for file in sorted((root / folder).rglob("*")):
            if not file.is_file() or not file.name.endswith(SOURCE_SUFFIXES):
                continue
            path = file.relative_to(root).as_posix()
            own = layer_index(path, by_name, by_folder)
            if own != by_folder[folder] and path not in FILE_LAYERS:
                continue  # a subfolder listed as a folder of its own is checked there
            checked += 1
            lines = file.read_text(encoding="utf-8", errors="replace").splitlines()
            for number, line in enumerate(lines, 1):
                match = INCLUDE.match(line)
                if not match:
                    continue
                header = match.group(1)
                if is_test_file(header) and not is_test_file(path):
                    problems.append(f"{path}:{number}: includes the test helper {header}")
                    continue
                if is_test_file(path):
                    continue
                target = layer_index(header, by_name, by_folder)
                if target is not None and target > own:
                    problems.append(
                        f"{path}:{number}: includes {header} of layer '{LAYERS[target][0]}', "
                        f"above its own layer '{LAYERS[own][0]}'"
                    )
    return checked, problems


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).parent.parent)
    checked, problems = check(root.resolve())
    for problem in problems:
        print(problem)
    if problems:
        print(f"check-layers: {len(problems)} include(s) against the layer order "
              "(docs/architecture.md, Layers)")
        return 1
    print(f"check-layers: {checked} files, every include within its layer or below")
    return 0


if __name__ == "__main__":
    sys.exit(main())
