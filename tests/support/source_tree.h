// Where the checkout that a build tree was configured from lies, for tests, benchmarks and fuzz
// harnesses that read its scenes, meshes and docs.
//
// The path is compiled into one small generated file (source_tree.cpp, made from
// source_tree.cpp.in) rather than given to every file as a compile definition: objects then do
// not depend on where the checkout is, so ccache reuses them in every clone (CI's clean clone
// included), and only that one file is compiled again.
#pragma once

#include <string>
#include <string_view>

namespace alphorn {

// The checkout's top directory, without a trailing slash.
const std::string& sourceDirectory();

// `relative` (a path inside the checkout, e.g. "scenes/cbox/cbox.xml") under sourceDirectory().
std::string sourcePath(std::string_view relative);

}  // namespace alphorn
