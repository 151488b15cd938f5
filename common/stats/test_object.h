// The root object of a Nori-format statistical test file (<test type="ttest"> or
// <test type="chi2test">). Unlike Nori, building the object does not run it: `alphorn test`
// parses the file, then calls run(), so that a parse error and a failed test are told apart.
#pragma once

#include "common/core/object.h"

#include <iosfwd>

namespace alphorn {

class StatisticalTest : public Object {
  public:
    ObjectKind kind() const override { return ObjectKind::Test; }

    struct Summary {
        int passed = 0;
        int total = 0;
        bool allPassed() const { return total > 0 && passed == total; }
    };
    // Runs every test case, writing one result line per case (PASS/FAIL with the statistics).
    // Deterministic: the random streams are fixed (StreamPurpose::Test).
    virtual Summary run(std::ostream& out) const = 0;
};

// Parses a list of floats separated by commas and/or whitespace ("0.5, 1 2"); fails naming
// the property list's source on anything else.
std::vector<float> parseFloatList(const PropertyList& props, const std::string& name);

}  // namespace alphorn
