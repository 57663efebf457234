#pragma once
// The one way ftid reads values from its YAML input files (configurations, parameter files,
// trajectories, the tare state). Loading is strict (yaml_strict.hpp: duplicate keys, depth, size);
// every value knows its file, its position and its full key path, so every error reads
//
//   FILE:LINE:COLUMN: key 'section.sub[2].name': problem
//
// (LINE and COLUMN 1-based; a missing key names the mapping it is missing from, a missing
// top-level key only the file). Typed getters refuse a value of the wrong kind, a non-finite
// number, an out-of-range value and a key with no value; `onlyKeys` refuses unknown keys (typos).
// Set-up code only (allocates and throws ConfigError).
#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace ftid {

/// Bounds of a number; `what` (optional) replaces the default message "must be in [a, b]".
struct NumberRange {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false;  ///< min itself is outside the range
  bool max_open = false;  ///< max itself is outside the range
  std::string what;

  bool contains(double v) const {
    return (min_open ? v > min : v >= min) && (max_open ? v < max : v <= max);
  }
  /// "must be in [0, 10]", "must be > 0", "must be >= 0", ... (or `what` when given).
  std::string describe() const;

  static NumberRange closed(double lo, double hi, std::string what = {}) { return {lo, hi, false, false, std::move(what)}; }
  static NumberRange positive(std::string what = {}) { return {0.0, kInf, true, false, std::move(what)}; }
  static NumberRange nonNegative(std::string what = {}) { return {0.0, kInf, false, false, std::move(what)}; }

 private:
  static constexpr double kInf = std::numeric_limits<double>::infinity();
};

/// One node of a loaded YAML file: its value, file, position and full key path. Cheap to copy.
/// A value can be absent (a key that is not in the file): `present()` is false, the getters
/// without a default throw "missing", those with a default return it.
class YamlValue {
 public:
  /// Full key path ("robot.rtde_port", "faults[2].kind"; "" for the document itself).
  const std::string& key() const { return key_; }
  const std::string& file() const { return *file_; }
  /// "FILE:LINE:COLUMN" of this value (of the mapping it is missing from, when absent; only FILE
  /// for a missing top-level key).
  std::string where() const;
  /// Throws ConfigError("WHERE: key 'KEY': what").
  [[noreturn]] void fail(const std::string& what) const;
  /// The message `fail` would throw, for callers that collect rather than throw.
  std::string message(const std::string& what) const;

  bool present() const { return node_.IsDefined(); }
  explicit operator bool() const { return present(); }
  bool isNull() const { return present() && node_.IsNull(); }
  bool isMap() const { return present() && node_.IsMap(); }
  bool isSequence() const { return present() && node_.IsSequence(); }
  bool isScalar() const { return present() && node_.IsScalar(); }
  const YAML::Node& node() const { return node_; }

  // ---- structure
  /// The child `name` of a mapping (absent if not there). Throws if this value is present but not
  /// a mapping.
  YamlValue operator[](std::string_view name) const;
  /// The child `name`; throws "missing" when it is absent.
  YamlValue required(std::string_view name) const;
  /// Element `i` of a sequence (key path "key[i]"); throws unless a sequence with that element.
  YamlValue at(std::size_t i) const;
  /// Number of elements of a sequence or entries of a mapping (0 when absent or null).
  std::size_t size() const;
  /// Throws "expected a mapping" unless this is a mapping (`what` replaces the text).
  const YamlValue& expectMap(const std::string& what = {}) const;
  /// Throws "expected a list" unless this is a sequence (`what` replaces the text).
  const YamlValue& expectSequence(const std::string& what = {}) const;
  /// Entries of a mapping in file order (keys must be plain scalars); throws unless a mapping.
  std::vector<std::pair<std::string, YamlValue>> entries() const;
  /// Elements of a sequence; throws unless a sequence.
  std::vector<YamlValue> elements() const;
  /// Throws at the first key of this mapping that is not in `known` ("unknown key (known keys
  /// here: a, b, c)"). Absent: nothing to check. Present but not a mapping: "expected a mapping".
  void onlyKeys(std::initializer_list<std::string_view> known) const;
  void onlyKeys(const std::vector<std::string>& known) const;

  // ---- scalars (each throws "missing" when absent and "has no value" for `key:` without one)
  /// The scalar's text as written (may be empty: `key: ""`).
  std::string text() const;
  /// The scalar's text, refusing an empty one.
  std::string nonEmptyText() const;
  /// A finite number (decimal or exponent notation; .inf/.nan and friends are "must be finite").
  double number() const;
  double number(const NumberRange& range) const;
  /// A whole decimal number within [min, max] (no fraction, no exponent).
  std::int64_t integer(std::int64_t min = std::numeric_limits<std::int64_t>::min(),
                       std::int64_t max = std::numeric_limits<std::int64_t>::max(),
                       const std::string& what = {}) const;
  /// true/false (also YAML 1.1's yes/no/on/off; lower, Title or UPPER case; not y/n).
  bool boolean() const;

  // ---- with a default when absent (a present value must still be valid)
  std::string textOr(const std::string& fallback) const { return present() ? text() : fallback; }
  double numberOr(double fallback) const { return present() ? number() : fallback; }
  double numberOr(double fallback, const NumberRange& range) const { return present() ? number(range) : fallback; }
  bool booleanOr(bool fallback) const { return present() ? boolean() : fallback; }
  std::int64_t integerOr(std::int64_t fallback, std::int64_t min = std::numeric_limits<std::int64_t>::min(),
                         std::int64_t max = std::numeric_limits<std::int64_t>::max(), const std::string& what = {}) const {
    return present() ? integer(min, max, what) : fallback;
  }

  // ---- lists of numbers
  /// A list of exactly `n` finite numbers.
  std::vector<double> numbers(std::size_t n) const;
  /// A list of finite numbers of any length.
  std::vector<double> numbers() const;
  /// A list of exactly N finite numbers as a fixed-size Eigen vector.
  template <int N>
  Eigen::Matrix<double, N, 1> vector() const {
    static_assert(N > 0, "fixed-size vectors only");
    const std::vector<double> v = numbers(static_cast<std::size_t>(N));
    Eigen::Matrix<double, N, 1> out;
    for (int i = 0; i < N; ++i) out[i] = v[static_cast<std::size_t>(i)];
    return out;
  }

 private:
  friend class YamlFile;
  YamlValue(std::shared_ptr<const std::string> file, YAML::Node node, std::string key, YAML::Mark mark)
      : file_(std::move(file)), node_(std::move(node)), key_(std::move(key)), mark_(mark) {}
  const std::string& scalar(const char* expected) const;  // text of a present scalar, or throws
  std::string childKey(std::string_view name) const;

  std::shared_ptr<const std::string> file_;
  YAML::Node node_;
  std::string key_;
  YAML::Mark mark_;  // of the node; of the parent mapping when absent (line -1: the file only)
};

/// A strictly loaded YAML document (yaml_strict.hpp) and the file it came from.
class YamlFile {
 public:
  /// Reads `path` with readInputFile (regular file, O_NONBLOCK, size bound; `what` names the kind
  /// of file in errors, "parameter file") and parses it strictly.
  static YamlFile load(const std::string& path, const std::string& what);
  /// Parses `text`, the contents of `path` (used in messages).
  static YamlFile parse(const std::string& text, const std::string& path);

  const std::string& path() const { return *path_; }
  /// The document (key path ""); null for an empty file.
  YamlValue root() const;

 private:
  YamlFile(std::shared_ptr<const std::string> path, YAML::Node root) : path_(std::move(path)), root_(std::move(root)) {}
  std::shared_ptr<const std::string> path_;
  YAML::Node root_;
};

}  // namespace ftid
