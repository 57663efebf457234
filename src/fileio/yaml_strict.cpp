// Strict YAML loading (include/ftid/fileio/yaml_strict.hpp).
#include "ftid/fileio/yaml_strict.hpp"

#include <string_view>
#include <unordered_map>

#include "ftid/common/error.hpp"
#include "ftid/fileio/input_file.hpp"

namespace ftid {

namespace {

constexpr std::size_t kMaxYamlNodes = 1000000;  // aliases can make a small file a huge tree

std::string at(const std::string& path, const YAML::Node& node) {
  const int line = node.Mark().line;
  return line >= 0 ? path + ":" + std::to_string(line + 1) : path;
}

void walk(const YAML::Node& node, const std::string& path, int depth, std::size_t& visited) {
  if (++visited > kMaxYamlNodes) {
    throw ConfigError(path + ": the YAML document is too large (over " + std::to_string(kMaxYamlNodes) +
                      " nodes, counting aliases)");
  }
  if (depth > kMaxYamlDepth) {
    throw ConfigError(at(path, node) + ": YAML nested deeper than " + std::to_string(kMaxYamlDepth) + " levels");
  }
  if (node.IsMap()) {
    std::unordered_map<std::string_view, int> seen;
    seen.reserve(node.size());
    for (const auto& kv : node) {
      if (kv.first.IsScalar()) {
        const int line = kv.first.Mark().line + 1;
        const auto [it, inserted] = seen.emplace(kv.first.Scalar(), line);
        if (!inserted) {
          throw ConfigError(at(path, kv.first) + ": duplicate key '" + kv.first.Scalar() + "' (first on line " +
                            std::to_string(it->second) + "); YAML keys must be unique");
        }
      } else {
        walk(kv.first, path, depth + 1, visited);
      }
      walk(kv.second, path, depth + 1, visited);
    }
  } else if (node.IsSequence()) {
    for (const auto& item : node) walk(item, path, depth + 1, visited);
  }
}

}  // namespace

void checkNoDuplicateKeys(const YAML::Node& root, const std::string& path) {
  std::size_t visited = 0;
  walk(root, path, 0, visited);
}

YAML::Node loadYamlStrict(const std::string& text, const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  }
  checkNoDuplicateKeys(root, path);
  return root;
}

YAML::Node loadYamlFileStrict(const std::string& path, const std::string& what) {
  std::string text;
  try {
    text = readInputFile(path, what, kMaxTextConfigBytes);
  } catch (const FileError& e) {
    throw ConfigError(e.what());
  }
  return loadYamlStrict(text, path);
}

}  // namespace ftid
