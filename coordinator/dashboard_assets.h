// The dashboard's pages, script and style sheet (the files in coordinator/dashboard/), compiled
// into the binary: CMake writes them into a generated dashboard_assets.cpp
// (dashboard/embed_assets.cmake), so the coordinator fetches nothing at run time and needs no
// file beside it.
#pragma once

#include <string_view>

namespace alphorn::coordinator {

struct DashboardAsset {
    std::string_view name;  // the file name, e.g. "jobs.html"
    std::string_view body;
};

// The asset of that file name, or nullptr.
const DashboardAsset* findDashboardAsset(std::string_view name);

}  // namespace alphorn::coordinator
