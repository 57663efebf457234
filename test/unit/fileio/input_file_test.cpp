// Reading untrusted inputs (include/ftid/fileio/input_file.hpp, yaml_strict.hpp): FIFOs and
// directories are refused without blocking, sizes are bounded, YAML duplicate keys are errors.
#include <sys/stat.h>

#include <gtest/gtest.h>

#include <functional>

#include "ftid/common/error.hpp"
#include "ftid/fileio/input_file.hpp"
#include "ftid/fileio/yaml_strict.hpp"
#include "scratch.hpp"

namespace ftid {
namespace {

using test::ScratchDir;
using test::spit;

std::string messageOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(InputFile, ReadsARegularFileAndFollowsSymlinks) {
  ScratchDir d("fileio");
  spit(d / "in.txt", "hello\n");
  EXPECT_EQ(readInputFile(d / "in.txt", "test file"), "hello\n");
  ASSERT_EQ(::symlink("in.txt", (d / "link").c_str()), 0);
  EXPECT_EQ(readInputFile(d / "link", "test file"), "hello\n");
}

TEST(InputFile, RefusesFifoAndDirectoryWithoutBlocking) {
  ScratchDir d("fileio");
  ASSERT_EQ(::mkfifo((d / "fifo").c_str(), 0600), 0);  // no writer: a blocking open would hang
  const std::string m1 = messageOf([&] { (void)readInputFile(d / "fifo", "log file"); });
  EXPECT_NE(m1.find(d / "fifo"), std::string::npos) << m1;
  EXPECT_NE(m1.find("FIFO"), std::string::npos) << m1;
  const std::string m2 = messageOf([&] { (void)readInputFile(d.path(), "parameter file"); });
  EXPECT_NE(m2.find(d.path()), std::string::npos) << m2;
  EXPECT_NE(m2.find("directory"), std::string::npos) << m2;
  EXPECT_NE(m2.find("parameter file"), std::string::npos) << m2;
  const std::string m3 = messageOf([&] { (void)readInputFile(d / "missing", "log file"); });
  EXPECT_NE(m3.find(d / "missing"), std::string::npos) << m3;
  const std::string m4 = messageOf([&] { (void)readInputFile("/dev/zero", "log file"); });
  EXPECT_NE(m4.find("character device"), std::string::npos) << m4;
}

TEST(InputFile, BoundsTheSize) {
  ScratchDir d("fileio");
  spit(d / "big", std::string(1000, 'x'));
  EXPECT_EQ(readInputFile(d / "big", "f", 1000).size(), 1000u);
  const std::string m = messageOf([&] { (void)readInputFile(d / "big", "f", 999); });
  EXPECT_NE(m.find("too large"), std::string::npos) << m;
}

TEST(YamlStrict, DuplicateKeysAreErrorsNamingBothLines) {
  const std::string m = messageOf([] { (void)loadYamlStrict("model: paper\nmass: 1\nmass: -2\n", "p.yaml"); });
  EXPECT_NE(m.find("p.yaml:3"), std::string::npos) << m;
  EXPECT_NE(m.find("duplicate key 'mass'"), std::string::npos) << m;
  EXPECT_NE(m.find("line 2"), std::string::npos) << m;
  // Nested and flow mappings too.
  EXPECT_THROW((void)loadYamlStrict("a:\n  b: {x: 1, x: 2}\n", "n.yaml"), ConfigError);
  EXPECT_THROW((void)loadYamlStrict("- {k: 1}\n- {k: 1, k: 1}\n", "s.yaml"), ConfigError);
  // Equal keys in different mappings are fine.
  EXPECT_NO_THROW((void)loadYamlStrict("a: {x: 1}\nb: {x: 1}\n", "ok.yaml"));
}

TEST(YamlStrict, SyntaxErrorsDepthAndAliasBombsAreBounded) {
  const std::string m = messageOf([] { (void)loadYamlStrict("a: [1, 2\n", "bad.yaml"); });
  EXPECT_NE(m.find("bad.yaml:"), std::string::npos) << m;
  std::string deep;
  for (int i = 0; i < kMaxYamlDepth + 5; ++i) deep += "[";
  for (int i = 0; i < kMaxYamlDepth + 5; ++i) deep += "]";
  EXPECT_THROW((void)loadYamlStrict(deep, "deep.yaml"), ConfigError);
  // "Billion laughs": each level doubles the tree seen through aliases.
  std::string bomb = "a0: &a0 [x, x]\n";
  for (int i = 1; i < 40; ++i) {
    bomb += "a" + std::to_string(i) + ": &a" + std::to_string(i) + " [*a" + std::to_string(i - 1) + ", *a" +
            std::to_string(i - 1) + "]\n";
  }
  const std::string mb = messageOf([&] { (void)loadYamlStrict(bomb, "bomb.yaml"); });
  EXPECT_NE(mb.find("bomb.yaml"), std::string::npos) << mb;
}

TEST(YamlStrict, FileLoaderRefusesAFifo) {
  ScratchDir d("fileio");
  ASSERT_EQ(::mkfifo((d / "cfg.yaml").c_str(), 0600), 0);
  EXPECT_THROW((void)loadYamlFileStrict(d / "cfg.yaml", "config file"), ConfigError);
}

}  // namespace
}  // namespace ftid
