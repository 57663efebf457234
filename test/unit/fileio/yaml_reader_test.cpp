// The one YAML value reader (include/ftid/fileio/yaml_reader.hpp): every getter's error names
// FILE:LINE:COLUMN and the full key path; wrong types, missing keys, keys without a value, unknown
// keys, non-finite and out-of-range numbers are refused.
#include <gtest/gtest.h>

#include <functional>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/fileio/yaml_reader.hpp"
#include "scratch.hpp"

namespace ftid {
namespace {

// Line 1..9; column of each value written out in the comments (1-based).
const char* const kDoc =
    "robot:\n"                           // 1
    "  host: 10.0.0.2\n"                 // 2  host value at column 9
    "  rtde_port: 30004\n"               // 3  value at column 14
    "  backoff_s: 0.5\n"                 // 4  value at column 14
    "  empty:\n"                         // 5
    "  flag: yes\n"                      // 6  value at column 9
    "mount: [0.1, 0.2, .nan]\n"          // 7  elements at columns 9, 14, 19
    "faults:\n"                          // 8
    "  - {at_s: 1.5, kind: drop}\n";     // 9  kind key at column 17, value at 23

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("(not a ConfigError) ") + e.what();
  }
  return "(no error)";
}

#define EXPECT_HAS(haystack, needle) EXPECT_NE((haystack).find(needle), std::string::npos) << (haystack)

class YamlReader : public ::testing::Test {
 protected:
  YamlFile file_ = YamlFile::parse(kDoc, "cfg/x.yaml");
  YamlValue root_ = file_.root();
};

TEST_F(YamlReader, ReadsTypedValues) {
  const YamlValue robot = root_["robot"];
  EXPECT_EQ(robot["host"].text(), "10.0.0.2");
  EXPECT_EQ(robot["rtde_port"].integer(1, 65535), 30004);
  EXPECT_DOUBLE_EQ(robot["backoff_s"].number(), 0.5);
  EXPECT_DOUBLE_EQ(robot["backoff_s"].number(NumberRange::positive()), 0.5);
  EXPECT_TRUE(robot["flag"].boolean());
  EXPECT_EQ(root_["faults"].at(0)["kind"].key(), "faults[0].kind");
  EXPECT_EQ(root_["faults"].at(0)["kind"].text(), "drop");
  EXPECT_EQ(root_["faults"].elements().size(), 1u);
  EXPECT_EQ(root_.entries().size(), 3u);
  EXPECT_EQ(root_.entries()[1].first, "mount");
  const auto v = YamlFile::parse("v: [1, -2.5e-1, +3]\n", "v.yaml").root()["v"].vector<3>();
  EXPECT_EQ(v, Eigen::Vector3d(1.0, -0.25, 3.0));
}

TEST(YamlReaderBoolean, WordsButNotLetters) {
  for (const char* t : {"true", "True", "TRUE", "yes", "on", "ON"}) {
    EXPECT_TRUE(YamlFile::parse(std::string("b: ") + t + "\n", "b.yaml").root()["b"].boolean()) << t;
  }
  for (const char* f : {"false", "False", "no", "NO", "off"}) {
    EXPECT_FALSE(YamlFile::parse(std::string("b: ") + f + "\n", "b.yaml").root()["b"].boolean()) << f;
  }
  for (const char* bad : {"y", "n", "1", "0", "tru", "'yes please'"}) {
    const YamlFile file = YamlFile::parse(std::string("b: ") + bad + "\n", "b.yaml");
    EXPECT_HAS(errorOf([&] { (void)file.root()["b"].boolean(); }), "b.yaml:1:4: key 'b': expected true or false, got");
  }
}

TEST_F(YamlReader, DefaultsOnlyForAbsentKeys) {
  const YamlValue robot = root_["robot"];
  EXPECT_FALSE(robot["nope"].present());
  EXPECT_DOUBLE_EQ(robot["nope"].numberOr(7.0), 7.0);
  EXPECT_EQ(robot["nope"].textOr("d"), "d");
  EXPECT_FALSE(robot["nope"].booleanOr(false));
  EXPECT_EQ(robot["nope"].integerOr(-4, -10, 10), -4);
  EXPECT_EQ(robot["rtde_port"].integerOr(-4), 30004);
  EXPECT_HAS(errorOf([&] { (void)robot["rtde_port"].integerOr(1, 1, 10); }), "cfg/x.yaml:3:14: key 'robot.rtde_port': must be in 1..10");
  EXPECT_DOUBLE_EQ(robot["backoff_s"].numberOr(7.0), 0.5);
  // A key written without a value is present, and not a valid number.
  EXPECT_HAS(errorOf([&] { (void)robot["empty"].numberOr(7.0); }),
             "cfg/x.yaml:5:3: key 'robot.empty': has no value (expected a number)");
  // A present value must be valid even with a default.
  EXPECT_HAS(errorOf([&] { (void)robot["host"].numberOr(7.0); }),
             "cfg/x.yaml:2:9: key 'robot.host': expected a number, got '10.0.0.2'");
}

TEST_F(YamlReader, WrongTypeNamesFileLineColumnAndKey) {
  const YamlValue robot = root_["robot"];
  EXPECT_HAS(errorOf([&] { (void)robot["host"].integer(); }),
             "cfg/x.yaml:2:9: key 'robot.host': expected an integer, got '10.0.0.2'");
  EXPECT_HAS(errorOf([&] { (void)robot["backoff_s"].integer(); }),
             "cfg/x.yaml:4:14: key 'robot.backoff_s': expected an integer, got '0.5'");
  EXPECT_HAS(errorOf([&] { (void)robot["host"].boolean(); }),
             "cfg/x.yaml:2:9: key 'robot.host': expected true or false, got '10.0.0.2'");
  EXPECT_HAS(errorOf([&] { (void)robot.text(); }), "cfg/x.yaml:2:3: key 'robot': expected a single value, got a mapping");
  EXPECT_HAS(errorOf([&] { (void)root_["mount"].number(); }), "cfg/x.yaml:7:8: key 'mount': expected a number, got a list");
  EXPECT_HAS(errorOf([&] { (void)robot["host"].numbers(3); }),
             "cfg/x.yaml:2:9: key 'robot.host': expected a list of 3 numbers");
  EXPECT_HAS(errorOf([&] { (void)root_["mount"].vector<2>(); }),
             "cfg/x.yaml:7:8: key 'mount': expected a list of 2 numbers, got 3");
  EXPECT_HAS(errorOf([&] { (void)root_["mount"]["x"]; }), "cfg/x.yaml:7:8: key 'mount': expected a mapping");
  EXPECT_HAS(errorOf([&] { (void)root_["mount"].entries(); }), "key 'mount': expected a mapping");
  EXPECT_HAS(errorOf([&] { (void)robot.elements(); }), "cfg/x.yaml:2:3: key 'robot': expected a list");
  EXPECT_HAS(errorOf([&] { (void)root_["faults"].at(3); }), "key 'faults': has no element 3");
}

TEST_F(YamlReader, MissingKeyNamesTheMappingItIsMissingFrom) {
  EXPECT_HAS(errorOf([&] { (void)root_["robot"].required("tip_link"); }), "cfg/x.yaml:2:3: key 'robot.tip_link': missing");
  EXPECT_HAS(errorOf([&] { (void)root_["robot"]["tip_link"].text(); }), "cfg/x.yaml:2:3: key 'robot.tip_link': missing");
  EXPECT_HAS(errorOf([&] { (void)root_["faults"].at(0).required("count"); }),
             "cfg/x.yaml:9:5: key 'faults[0].count': missing");
  // At the top level there is no line to name: the file and the key.
  EXPECT_EQ(errorOf([&] { (void)root_.required("duration_s"); }), "cfg/x.yaml: key 'duration_s': missing");
  EXPECT_EQ(errorOf([&] { (void)root_["a"]["b"].number(); }), "cfg/x.yaml: key 'a.b': missing");
  // Below an absent key: still the mapping where the chain leaves the file.
  EXPECT_EQ(errorOf([&] { (void)root_["robot"]["tcp"]["x"].number(); }), "cfg/x.yaml:2:3: key 'robot.tcp.x': missing");
}

TEST_F(YamlReader, UnknownKeyIsNamedWithTheKnownOnes) {
  const std::string m = errorOf([&] { root_["robot"].onlyKeys({"host", "rtde_port", "backoff_s", "empty"}); });
  EXPECT_HAS(m, "cfg/x.yaml:6:3: key 'robot.flag': unknown key (known keys here: host, rtde_port, backoff_s, empty)");
  EXPECT_HAS(errorOf([&] { root_.onlyKeys({"robot", "mount"}); }), "cfg/x.yaml:8:1: key 'faults': unknown key");
  EXPECT_HAS(errorOf([&] { root_["faults"].at(0).onlyKeys({"at_s"}); }), "cfg/x.yaml:9:17: key 'faults[0].kind': unknown key");
  EXPECT_EQ(errorOf([&] { root_.onlyKeys({"robot", "mount", "faults"}); }), "(no error)");
  EXPECT_EQ(errorOf([&] { root_["absent"].onlyKeys({"x"}); }), "(no error)");
  EXPECT_HAS(errorOf([&] { root_["mount"].onlyKeys({"x"}); }), "cfg/x.yaml:7:8: key 'mount': expected a mapping");
}

TEST_F(YamlReader, NonFiniteNumbersAreRefused) {
  EXPECT_HAS(errorOf([&] { (void)root_["mount"].vector<3>(); }), "cfg/x.yaml:7:19: key 'mount[2]': must be finite, got '.nan'");
  for (const char* bad : {".inf", "-.Inf", ".NaN", "1e999", "inf", "-Infinity", "nan", "NaN"}) {
    const YamlFile f = YamlFile::parse(std::string("x: ") + bad + "\n", "n.yaml");
    const std::string m = errorOf([&] { (void)f.root()["x"].number(); });
    EXPECT_HAS(m, "n.yaml:1:4: key 'x': ");
    EXPECT_HAS(m, std::string("must be finite, got '") + bad + "'");
  }
  for (const char* bad : {"0x10", "1.5abc", "1,5", "''", "1e", "."}) {
    const YamlFile f = YamlFile::parse(std::string("x: ") + bad + "\n", "n.yaml");
    EXPECT_HAS(errorOf([&] { (void)f.root()["x"].number(); }), "n.yaml:1:4: key 'x': expected a number") << bad;
  }
}

TEST_F(YamlReader, OutOfRangeNamesTheRangeAndTheValue) {
  const YamlValue robot = root_["robot"];
  EXPECT_HAS(errorOf([&] { (void)robot["backoff_s"].number(NumberRange::closed(1.0, 60.0)); }),
             "cfg/x.yaml:4:14: key 'robot.backoff_s': must be in [1.0, 60.0], got 0.5");
  EXPECT_HAS(errorOf([&] { (void)robot["backoff_s"].number({0.5, 1.0, true, false, {}}); }),
             "key 'robot.backoff_s': must be in (0.5, 1.0], got 0.5");
  EXPECT_HAS(errorOf([&] { (void)robot["backoff_s"].number(NumberRange::closed(1.0, 60.0, "must be in 1..60 s")); }),
             "cfg/x.yaml:4:14: key 'robot.backoff_s': must be in 1..60 s, got 0.5");
  EXPECT_HAS(errorOf([&] { (void)robot["rtde_port"].integer(1, 1024); }),
             "cfg/x.yaml:3:14: key 'robot.rtde_port': must be in 1..1024, got 30004");
  EXPECT_HAS(errorOf([&] { (void)robot["rtde_port"].integer(1, 1024, "must be a port below 1025"); }),
             "key 'robot.rtde_port': must be a port below 1025, got 30004");
  const YamlFile f = YamlFile::parse("n: -0.0\nbig: 99999999999999999999\n", "r.yaml");
  EXPECT_HAS(errorOf([&] { (void)f.root()["n"].number(NumberRange::positive()); }), "r.yaml:1:4: key 'n': must be > 0");
  EXPECT_DOUBLE_EQ(f.root()["n"].number(NumberRange::nonNegative()), 0.0);
  EXPECT_HAS(errorOf([&] { (void)f.root()["big"].integer(); }), "r.yaml:2:6: key 'big': expected an integer");
}

TEST_F(YamlReader, EmptyTextAndEmptyDocument) {
  const YamlFile f = YamlFile::parse("name: ''\n", "e.yaml");
  EXPECT_EQ(f.root()["name"].text(), "");
  EXPECT_HAS(errorOf([&] { (void)f.root()["name"].nonEmptyText(); }), "e.yaml:1:7: key 'name': must not be empty");
  const YamlFile empty = YamlFile::parse("", "empty.yaml");
  EXPECT_TRUE(empty.root().isNull());
  EXPECT_FALSE(empty.root()["x"].present());
  EXPECT_EQ(empty.root()["x"].numberOr(2.0), 2.0);
  EXPECT_HAS(errorOf([&] { (void)empty.root().expectMap(); }), "empty.yaml: key '(top level)': has no value");
}

// Whatever the document's shape, every getter either returns or throws ConfigError (never a
// yaml-cpp exception, which a reader would let escape as a crash).
TEST(YamlReaderShapes, EveryGetterOnEveryShapeThrowsOnlyConfigError) {
  const char* const docs[] = {"", "3", "[1, 2]", "~", "a:", "a: ~", "a: [1, {b: 2}]", "a: {b: [x]}", "? [1, 2]\n: 3\n",
                              "a: &x {b: 1}\nc: *x\n", "a: !!binary aGk=\n", "a: {? {k: 1} : v}\n", "- - - 1\n"};
  for (const char* text : docs) {
    const YamlFile f = YamlFile::parse(text, "s.yaml");
    const std::vector<std::function<void(const YamlValue&)>> getters = {
        [](const YamlValue& v) { (void)v.text(); },         [](const YamlValue& v) { (void)v.nonEmptyText(); },
        [](const YamlValue& v) { (void)v.number(); },       [](const YamlValue& v) { (void)v.integer(); },
        [](const YamlValue& v) { (void)v.boolean(); },      [](const YamlValue& v) { (void)v.numbers(); },
        [](const YamlValue& v) { (void)v.vector<2>(); },    [](const YamlValue& v) { (void)v.entries(); },
        [](const YamlValue& v) { (void)v.elements(); },     [](const YamlValue& v) { v.onlyKeys({"a"}); },
        [](const YamlValue& v) { (void)v.required("a"); },  [](const YamlValue& v) { (void)v.at(0); },
        [](const YamlValue& v) { (void)v.size(); },         [](const YamlValue& v) { (void)v.numberOr(1.0); }};
    std::vector<YamlValue> values = {f.root()};
    for (std::size_t k = 0; k < values.size() && k < 50; ++k) {  // the document's values, breadth first
      const YamlValue v = values[k];
      if (v.isMap()) {
        try {
          for (const auto& e : v.entries()) values.push_back(e.second);
        } catch (const ConfigError&) {
        }
        values.push_back(v["a"]);
        values.push_back(v["missing"]);
      } else if (v.isSequence()) {
        for (const auto& e : v.elements()) values.push_back(e);
      }
    }
    for (const YamlValue& v : values) {
      for (const auto& g : getters) {
        const std::string m = errorOf([&] { g(v); });
        EXPECT_EQ(m.find("(not a ConfigError)"), std::string::npos) << text << " / " << v.key() << ": " << m;
        if (m != "(no error)") {
          EXPECT_EQ(m.rfind("s.yaml", 0), 0u) << m;
        }
      }
    }
  }
}

TEST(YamlFileLoad, NamesTheFileAndKeepsTheStrictChecks) {
  test::ScratchDir d("yamlreader");
  EXPECT_HAS(errorOf([&] { (void)YamlFile::load(d / "missing.yaml", "design configuration"); }), d / "missing.yaml");
  test::spit(d / "dup.yaml", "a: 1\na: 2\n");
  EXPECT_HAS(errorOf([&] { (void)YamlFile::load(d / "dup.yaml", "x"); }), d / "dup.yaml" + ":2: duplicate key 'a'");
  test::spit(d / "syntax.yaml", "a: [1, 2\n");
  EXPECT_HAS(errorOf([&] { (void)YamlFile::load(d / "syntax.yaml", "x"); }), d / "syntax.yaml" + ":");
  test::spit(d / "ok.yaml", "a:\n  b: 3\n");
  const YamlFile f = YamlFile::load(d / "ok.yaml", "x");
  EXPECT_EQ(f.path(), d / "ok.yaml");
  EXPECT_EQ(f.root()["a"]["b"].integer(), 3);
}

}  // namespace
}  // namespace ftid
