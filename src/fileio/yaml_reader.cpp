// Reading typed values from YAML files with FILE:LINE:COLUMN: key 'a.b' errors
// (include/ftid/fileio/yaml_reader.hpp).
#include "ftid/fileio/yaml_reader.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "ftid/common/error.hpp"
#include "ftid/fileio/input_file.hpp"
#include "ftid/fileio/yaml_emit.hpp"
#include "ftid/fileio/yaml_strict.hpp"

namespace ftid {

namespace {

/// YAML's special floats (.inf, -.Inf, .NaN, ...) and C's (inf, -Infinity, nan): numbers, but
/// never finite ones (so the message says "must be finite", not "expected a number").
bool specialFloat(const std::string& t, double& out) {
  std::string s;
  for (const char ch : t) s += static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  double sign = 1.0;
  if (!s.empty() && (s[0] == '+' || s[0] == '-')) {
    sign = s[0] == '-' ? -1.0 : 1.0;
    s.erase(0, 1);
  }
  if (s == ".inf" || s == "inf" || s == "infinity") {
    out = sign * std::numeric_limits<double>::infinity();
    return true;
  }
  if (s == ".nan" || s == "nan") {
    out = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  return false;
}

/// The whole text is one decimal number (sign, digits, point, exponent; no hex, no spaces).
bool parseNumber(const std::string& t, double& out) {
  if (specialFloat(t, out)) return true;
  if (t.empty()) return false;
  for (const char ch : t) {
    const bool ok = (ch >= '0' && ch <= '9') || ch == '.' || ch == '+' || ch == '-' || ch == 'e' || ch == 'E';
    if (!ok) return false;  // refuses "0x10", " 1", "1_000", "1,5"
  }
  char* end = nullptr;
  out = std::strtod(t.c_str(), &end);
  return end == t.c_str() + t.size();  // an overflow (1e999) is inf: "must be finite"
}

bool parseInteger(const std::string& t, std::int64_t& out) {
  std::size_t i = (!t.empty() && (t[0] == '+' || t[0] == '-')) ? 1 : 0;
  if (i >= t.size() || t.size() - i > 19) return false;
  for (std::size_t k = i; k < t.size(); ++k) {
    if (t[k] < '0' || t[k] > '9') return false;
  }
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(t.c_str(), &end, 10);
  if (errno == ERANGE || end != t.c_str() + t.size()) return false;
  out = static_cast<std::int64_t>(v);
  return true;
}

/// Where a mapping's value is; for `key:` without a value, yaml-cpp marks the next token (often
/// the next line), so the key's own position is named instead.
YAML::Mark valueMark(const YAML::Node& key, const YAML::Node& value) {
  return value.IsNull() ? key.Mark() : value.Mark();
}

}  // namespace

std::string NumberRange::describe() const {
  if (!what.empty()) return what;
  const bool has_min = std::isfinite(min);
  const bool has_max = std::isfinite(max);
  if (has_min && has_max) {
    return std::string("must be in ") + (min_open ? "(" : "[") + yamlNumberText(min) + ", " + yamlNumberText(max) +
           (max_open ? ")" : "]");
  }
  if (has_min) return std::string("must be ") + (min_open ? "> " : ">= ") + yamlNumberText(min);
  if (has_max) return std::string("must be ") + (max_open ? "< " : "<= ") + yamlNumberText(max);
  return "must be a number";
}

// ------------------------------------------------------------------------------------ YamlValue

std::string YamlValue::where() const {
  if (mark_.line < 0) return *file_;
  return *file_ + ":" + std::to_string(mark_.line + 1) + ":" + std::to_string(mark_.column + 1);
}

std::string YamlValue::message(const std::string& what) const {
  return where() + ": key '" + (key_.empty() ? std::string("(top level)") : key_) + "': " + what;
}

void YamlValue::fail(const std::string& what) const { throw ConfigError(message(what)); }

std::string YamlValue::childKey(std::string_view name) const {
  return key_.empty() ? std::string(name) : key_ + "." + std::string(name);
}

YamlValue YamlValue::operator[](std::string_view name) const {
  if (!present() || node_.IsNull()) {
    // Nothing here: the child is absent too (a `section:` without entries has no keys).
    // Its position is this value's (or, when this is absent too, that of the mapping it is missing from).
    return YamlValue(file_, YAML::Node(YAML::NodeType::Undefined), childKey(name), mark_);
  }
  if (!node_.IsMap()) fail("expected a mapping (containing '" + std::string(name) + "')");
  const YAML::Node& n = node_;  // const access: never inserts
  for (const auto& kv : n) {
    if (kv.first.IsScalar() && kv.first.Scalar() == name) {
      return YamlValue(file_, kv.second, childKey(name), valueMark(kv.first, kv.second));
    }
  }
  return YamlValue(file_, YAML::Node(YAML::NodeType::Undefined), childKey(name),
                   key_.empty() ? YAML::Mark::null_mark() : mark_);
}

YamlValue YamlValue::required(std::string_view name) const {
  YamlValue v = (*this)[name];
  if (!v.present()) v.fail("missing");
  return v;
}

YamlValue YamlValue::at(std::size_t i) const {
  expectSequence();
  if (i >= node_.size()) fail("has no element " + std::to_string(i));
  const YAML::Node item = node_[i];
  return YamlValue(file_, item, key_ + "[" + std::to_string(i) + "]", item.Mark());
}

std::size_t YamlValue::size() const {
  if (!present() || node_.IsNull() || node_.IsScalar()) return 0;
  return node_.size();
}

const YamlValue& YamlValue::expectMap(const std::string& what) const {
  if (!present()) fail("missing");
  if (!node_.IsMap()) fail(what.empty() ? (node_.IsNull() ? "has no value (expected a mapping)" : "expected a mapping") : what);
  return *this;
}

const YamlValue& YamlValue::expectSequence(const std::string& what) const {
  if (!present()) fail("missing");
  if (!node_.IsSequence()) fail(what.empty() ? (node_.IsNull() ? "has no value (expected a list)" : "expected a list") : what);
  return *this;
}

std::vector<std::pair<std::string, YamlValue>> YamlValue::entries() const {
  expectMap();
  std::vector<std::pair<std::string, YamlValue>> out;
  out.reserve(node_.size());
  for (const auto& kv : node_) {
    if (!kv.first.IsScalar()) {
      YamlValue(file_, kv.first, key_, kv.first.Mark()).fail("keys must be plain names");
    }
    const std::string name = kv.first.Scalar();
    out.emplace_back(name, YamlValue(file_, kv.second, childKey(name), valueMark(kv.first, kv.second)));
  }
  return out;
}

std::vector<YamlValue> YamlValue::elements() const {
  expectSequence();
  std::vector<YamlValue> out;
  out.reserve(node_.size());
  for (std::size_t i = 0; i < node_.size(); ++i) out.push_back(at(i));
  return out;
}

void YamlValue::onlyKeys(std::initializer_list<std::string_view> known) const {
  std::vector<std::string> list;
  list.reserve(known.size());
  for (const auto k : known) list.emplace_back(k);
  onlyKeys(list);
}

void YamlValue::onlyKeys(const std::vector<std::string>& known) const {
  if (!present()) return;
  expectMap();
  for (const auto& kv : node_) {
    const std::string name = kv.first.IsScalar() ? kv.first.Scalar() : std::string();
    bool ok = false;
    for (const auto& k : known) ok = ok || (kv.first.IsScalar() && k == name);
    if (!ok) {
      std::string names;
      for (const auto& k : known) names += (names.empty() ? "" : ", ") + k;
      YamlValue(file_, kv.first, kv.first.IsScalar() ? childKey(name) : key_, kv.first.Mark())
          .fail((kv.first.IsScalar() ? "unknown key" : "keys must be plain names") + std::string(" (known keys here: ") +
                names + ")");
    }
  }
}

const std::string& YamlValue::scalar(const char* expected) const {
  if (!present()) fail("missing");
  if (node_.IsNull()) fail(std::string("has no value (expected ") + expected + ")");
  if (!node_.IsScalar()) fail(std::string("expected ") + expected + (node_.IsMap() ? ", got a mapping" : ", got a list"));
  return node_.Scalar();
}

std::string YamlValue::text() const { return scalar("a single value"); }

std::string YamlValue::nonEmptyText() const {
  std::string t = scalar("a single value");
  if (t.empty()) fail("must not be empty");
  return t;
}

double YamlValue::number() const {
  const std::string& t = scalar("a number");
  double v = 0.0;
  if (!parseNumber(t, v)) fail("expected a number, got '" + t + "'");
  if (!std::isfinite(v)) fail("must be finite, got '" + t + "'");
  return v;
}

double YamlValue::number(const NumberRange& range) const {
  const double v = number();
  if (!range.contains(v)) fail(range.describe() + ", got " + node_.Scalar());
  return v;
}

std::int64_t YamlValue::integer(std::int64_t min, std::int64_t max, const std::string& what) const {
  const std::string& t = scalar("an integer");
  std::int64_t v = 0;
  if (!parseInteger(t, v)) fail("expected an integer, got '" + t + "'");
  if (v < min || v > max) {
    fail((what.empty() ? "must be in " + std::to_string(min) + ".." + std::to_string(max) : what) + ", got " + t);
  }
  return v;
}

bool YamlValue::boolean() const {
  const std::string& t = scalar("true or false");
  bool v = false;
  // YAML 1.1's words (true/yes/on, false/no/off, as lower, Title or UPPER case), but not its
  // single letters y/n: a stray letter is more likely a mistake than a decision.
  if (t.size() < 2 || !YAML::convert<bool>::decode(node_, v)) fail("expected true or false, got '" + t + "'");
  return v;
}

std::vector<double> YamlValue::numbers(std::size_t n) const {
  if (!present()) fail("missing");
  if (!node_.IsSequence()) fail("expected a list of " + std::to_string(n) + " numbers");
  if (node_.size() != n) {
    fail("expected a list of " + std::to_string(n) + " numbers, got " + std::to_string(node_.size()));
  }
  return numbers();
}

std::vector<double> YamlValue::numbers() const {
  expectSequence("expected a list of numbers");
  std::vector<double> out;
  out.reserve(node_.size());
  for (std::size_t i = 0; i < node_.size(); ++i) out.push_back(at(i).number());
  return out;
}

// ------------------------------------------------------------------------------------- YamlFile

YamlFile YamlFile::load(const std::string& path, const std::string& what) {
  return YamlFile(std::make_shared<const std::string>(path), loadYamlFileStrict(path, what));
}

YamlFile YamlFile::parse(const std::string& text, const std::string& path) {
  return YamlFile(std::make_shared<const std::string>(path), loadYamlStrict(text, path));
}

YamlValue YamlFile::root() const { return YamlValue(path_, root_, "", root_.Mark()); }

}  // namespace ftid
