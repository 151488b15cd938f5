#include "common/sampler/sampler.h"
#include "common/texture/plugin_testing.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <vector>

namespace alphorn {
namespace {

// Each thread draws from a clone of the scene's sampler and writes its state at every draw: a
// clone must begin a cache line and fill whole lines, so that no other thread's data shares
// them (two-thread renders were up to 1.5x slower when the heap put a clone beside hot data).
TEST(SamplerLayout, EveryCloneHasCacheLinesOfItsOwn) {
    for (const char* type : {"independent", "stratified", "sobol"}) {
        SCOPED_TRACE(type);
        const std::shared_ptr<Sampler> sampler = plugin_testing::parseAs<Sampler>(
            "sampler.xml", std::string("<sampler type=\"") + type + "\"/>");
        std::vector<std::unique_ptr<Sampler>> clones;
        std::vector<std::unique_ptr<char[]>> between;  // small blocks the heap may put beside
        for (int i = 0; i < 8; ++i) {
            clones.push_back(sampler->clone());
            between.push_back(std::make_unique<char[]>(24));
        }
        for (const auto& clone : clones)
            EXPECT_EQ(reinterpret_cast<uintptr_t>(clone.get()) % 128, 0u);
        for (const auto& block : between)
            for (const auto& clone : clones) {
                const auto begin = reinterpret_cast<uintptr_t>(clone.get());
                const auto address = reinterpret_cast<uintptr_t>(block.get());
                // alignof(Sampler) pads every sampler type to whole 128-byte lines.
                EXPECT_FALSE(address >= begin && address < begin + 128);
            }
    }
}

}  // namespace
}  // namespace alphorn
