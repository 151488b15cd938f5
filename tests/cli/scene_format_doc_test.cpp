// docs/scene-format.md lists every plugin the engine registers: each (tag, type) pair of the
// plugin registry must appear in it, either in a heading that names both ("## bsdf `normalmap`")
// or as a table row "| `type` |" under a heading that names the tag ("## bsdf", "### medium").
#include "common/core/object.h"
#include "tests/support/source_tree.h"

#include <absl/strings/match.h>
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace alphorn {
namespace {

const std::vector<ObjectKind> kDocumentedKinds = {
    ObjectKind::Mesh,          ObjectKind::BSDF,    ObjectKind::Texture, ObjectKind::Medium,
    ObjectKind::PhaseFunction, ObjectKind::Emitter, ObjectKind::Camera,  ObjectKind::Integrator,
    ObjectKind::Sampler,       ObjectKind::Filter,  ObjectKind::Test};

// Whether a heading names the element tag as a word of its own (so "## bsdf" and "## emitter
// `spotlight`" name bsdf and emitter, but "## Participating media" names no tag).
bool headingNamesTag(const std::string& heading, const std::string& tag) {
    std::string words = heading;
    for (char& c : words)
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') c = ' ';
    std::istringstream in(words);
    for (std::string word; in >> word;)
        if (word == tag) return true;
    return false;
}

// The (tag, type) pairs the document lists.
std::set<std::pair<std::string, std::string>> documentedPairs(const std::string& path) {
    std::ifstream file(path);
    EXPECT_TRUE(file) << "cannot open " << path;
    std::set<std::pair<std::string, std::string>> pairs;
    std::vector<std::string> headingTags;  // the tags the current section is about
    std::set<std::string> allTags;
    for (ObjectKind kind : kDocumentedKinds) allTags.insert(kindTag(kind));
    for (std::string line; std::getline(file, line);) {
        if (absl::StartsWith(line, "#")) {
            headingTags.clear();
            for (const std::string& tag : allTags)
                if (headingNamesTag(line, tag)) headingTags.push_back(tag);
            // "## bsdf `normalmap`": every backquoted word is a type of the named tags.
            for (size_t open = line.find('`'); open != std::string::npos;
                 open = line.find('`', line.find('`', open + 1) + 1)) {
                const size_t close = line.find('`', open + 1);
                if (close == std::string::npos) break;
                const std::string quoted = line.substr(open + 1, close - open - 1);
                for (const std::string& tag : headingTags) pairs.emplace(tag, quoted);
                // "`bsdf null`" names a tag and a type together.
                const size_t space = quoted.find(' ');
                if (space != std::string::npos && allTags.count(quoted.substr(0, space)))
                    pairs.emplace(quoted.substr(0, space), quoted.substr(space + 1));
            }
        } else if (absl::StartsWith(line, "| `")) {
            const size_t close = line.find('`', 3);
            if (close == std::string::npos) continue;
            for (const std::string& tag : headingTags)
                pairs.emplace(tag, line.substr(3, close - 3));
        }
    }
    return pairs;
}

TEST(SceneFormatDoc, ListsEveryRegisteredTagAndType) {
    const auto pairs = documentedPairs(sourcePath("docs/scene-format.md"));
    int registered = 0;
    for (ObjectKind kind : kDocumentedKinds)
        for (const std::string& type : ObjectFactory::typesOf(kind)) {
            ++registered;
            EXPECT_TRUE(pairs.count({kindTag(kind), type}))
                << "docs/scene-format.md does not document <" << kindTag(kind) << " type=\"" << type
                << "\">: add it to the table of its element (a row \"| `" << type
                << "` | ...\") or a heading \"## " << kindTag(kind) << " `" << type << "`\"";
        }
    // Guards against a vacuous pass: the registry really was linked in.
    EXPECT_GT(registered, 40);
}

// Every parameter a plugin reads when built from an empty property list (up to the first
// required one it misses) appears in the document as `name`.
TEST(SceneFormatDoc, NamesEveryParameterThePluginsRead) {
    std::ifstream file(sourcePath("docs/scene-format.md"));
    std::stringstream text;
    text << file.rdbuf();
    const std::string doc = text.str();
    int checked = 0;
    for (ObjectKind kind : kDocumentedKinds)
        for (const std::string& type : ObjectFactory::typesOf(kind)) {
            PropertyList props("scene-format test");
            try {
                ObjectFactory::create(kind, type, props);
            } catch (const std::exception&) {
                // A required parameter is missing: those read before it are still listed.
            }
            for (const std::string& name : props.requestedNames()) {
                ++checked;
                EXPECT_NE(doc.find("`" + name + "`"), std::string::npos)
                    << "docs/scene-format.md does not name the parameter `" << name << "` of <"
                    << kindTag(kind) << " type=\"" << type << "\">";
            }
        }
    EXPECT_GT(checked, 60);
}

}  // namespace
}  // namespace alphorn
