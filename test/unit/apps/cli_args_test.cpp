// Strict numbers on the command line (apps/common/cli_args.hpp): the whole text is the number, reals
// are finite and in range, whole numbers are decimal (CLI11 by itself reads "010" as 8 and "-1" as
// 2^64-1 for an unsigned target), and every mistake is a UsageError naming the option.
#include "cli_args.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace ftid::cli {
namespace {

std::string usageError(const std::function<void()>& f) {
  try {
    f();
  } catch (const UsageError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(CliArgs, ValidatedOptionsGetExactlyTheCheckedValue) {
  int port = 0;
  std::uint64_t seed = 0;
  double rate = 0.0;
  std::vector<double> com;
  CLI::App app{"t"};
  app.add_option("--port", port)->transform(integer(1, 65535));
  app.add_option("--seed", seed)->transform(count());
  app.add_option("--rate", rate)->transform(real(positive()));
  addReals(app, "--com", com, 3);
  parse(app, {"--port", "010", "--seed=18446744073709551615", "--rate", "0.1", "--com", "-1e-3,+2,0.30000000000000004"});
  EXPECT_EQ(port, 10);  // decimal, not octal
  EXPECT_EQ(seed, std::numeric_limits<std::uint64_t>::max());
  EXPECT_EQ(rate, 0.1);  // bit for bit
  ASSERT_EQ(com.size(), 3u);
  EXPECT_EQ(com[0], -1e-3);
  EXPECT_EQ(com[1], 2.0);
  EXPECT_EQ(com[2], 0.30000000000000004);
}

TEST(CliArgs, BadNumbersAreUsageErrorsNamingTheOption) {
  const auto attempt = [](const std::vector<std::string>& args) {
    return usageError([&] {
      int port = 0;
      std::uint64_t seed = 0;
      double rate = 0.0, tilt = 0.0;
      std::vector<double> com;
      CLI::App app{"t"};
      app.add_option("--port", port)->transform(integer(1, 65535));
      app.add_option("--seed", seed)->transform(count());
      app.add_option("--rate", rate)->transform(real(positive()));
      app.add_option("--tilt", tilt)->transform(real());
      addReals(app, "--com", com, 3);
      parse(app, args);
    });
  };
  for (const std::vector<std::string>& args :
       std::vector<std::vector<std::string>>{{"--port", "abc"},     {"--port", "12x"},    {"--port", "70000"},
                                             {"--port", "0"},       {"--port", " 5"},     {"--port", "0x10"},
                                             {"--port", ""},        {"--port"},           {"--seed", "-1"},
                                             {"--seed", "1e3"},     {"--seed", "99999999999999999999"},
                                             {"--rate", "0"},       {"--rate", "-1"},     {"--rate", "nan"},
                                             {"--rate", "inf"},     {"--rate", "1e400"},  {"--rate", "5 "},
                                             {"--tilt", "1deg"},    {"--com", "1,2"},     {"--com", "1,2,3,4"},
                                             {"--com", "1,,3"},     {"--com", "1,2,nan"}}) {
    const std::string msg = attempt(args);
    EXPECT_EQ(msg.rfind(args[0], 0), 0u) << args[0] << " " << (args.size() > 1 ? args[1] : "") << ": " << msg;
  }
  EXPECT_NE(attempt({"--bogus"}).find("--bogus"), std::string::npos);
  EXPECT_NE(attempt({"stray"}).find("stray"), std::string::npos);
  // Negative numbers are values, not options.
  EXPECT_EQ(attempt({"--tilt", "-1.5", "--com", "-1,-2,-3"}), "(accepted)");
}

TEST(CliArgs, NumbersInsideLargerArguments) {
  EXPECT_EQ(parseReal("2.5", "--fault SECONDS"), 2.5);
  EXPECT_EQ(parseInteger("+7", "--fault COUNT", 1, 10), 7);
  EXPECT_EQ(parseCount("007", "--seed"), 7u);
  EXPECT_EQ(parseReals("1;2;3", "--x", 3, {}, ';'), (std::vector<double>{1.0, 2.0, 3.0}));
  EXPECT_NE(usageError([] { parseReal("2.5s", "--fault SECONDS"); }).find("--fault SECONDS: '2.5s'"),
            std::string::npos);
  EXPECT_NE(usageError([] { parseInteger("11", "--fault COUNT", 1, 10); }).find("in 1..10"), std::string::npos);
  EXPECT_NE(usageError([] { parseInteger("+-1", "n", -5, 5); }), "(accepted)");
  EXPECT_NE(usageError([] { parseReals("1,2", "--q0", 6); }).find("expected 6 values"), std::string::npos);
  EXPECT_NE(usageError([] { parseReal("0", "--hold", positive()); }).find("a number > 0"), std::string::npos);
  EXPECT_NE(usageError([] { parseReal("10.5", "--max-delay", {0.0, 10.0, true, false}); }).find("(0, 10]"),
            std::string::npos);
}

TEST(CliArgs, RepeatableOptionsTakeOneValueEach) {
  std::vector<std::string> effects;
  std::string log;
  CLI::App app{"t"};
  addRepeatable(app, "--effect", effects);
  app.add_option("LOG", log);
  parse(app, {"--effect", "cable:k=5", "run.csv", "--effect", "sensor_delay"});
  EXPECT_EQ(effects, (std::vector<std::string>{"cable:k=5", "sensor_delay"}));
  EXPECT_EQ(log, "run.csv");
}

TEST(CliArgs, WordsFromAList) {
  std::string method;
  CLI::App app{"t"};
  app.add_option("--method", method)->transform(oneOf({"static", "dynamic"}));
  EXPECT_NE(usageError([&] { parse(app, {"--method", "fast"}); }).find("'fast' is not one of: static, dynamic"),
            std::string::npos);
}

}  // namespace
}  // namespace ftid::cli
