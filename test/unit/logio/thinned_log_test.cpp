// Long logs read in one pass within a row budget (readLogThinned, FileLineCursor;
// docs/log-format.md "Limits"). The reference for every streamed result is the whole-file reader
// (readLog, LineCursor over the whole text), and the kept rows are recomputed here from the
// documented rule by counting rows, not by the thinner.
#include <sys/stat.h>

#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "file_lines.hpp"
#include "ftid/common/error.hpp"
#include "ftid/logio/input.hpp"
#include "ftid/logio/log.hpp"
#include "line_cursor.hpp"
#include "row_thinner.hpp"
#include "test_paths.hpp"

namespace ftid::logio {
namespace {

std::string writeText(const std::string& name, const std::string& text) {
  const std::string path = ftid::test::binaryPath("/thinned_log_test_") + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

const char* kHeader = "t,q1,q2,q3,q4,q5,q6,qd1,qd2,qd3,qd4,qd5,qd6,qdd1,qdd2,qdd3,qdd4,qdd5,qdd6,fx,fy,fz,tx,ty,tz";

/// One row at time t: moving (every qd 0.2 rad/s) or holding still (qd 0); the wrench encodes the row.
std::string row(std::size_t i, bool moving, const std::string& extras = "") {
  std::ostringstream s;
  s.precision(17);
  s << 0.008 * static_cast<double>(i);
  for (int j = 0; j < 6; ++j) s << "," << 0.001 * static_cast<double>(i % 1000) + j;
  for (int j = 0; j < 6; ++j) s << "," << (moving ? 0.2 : 0.0);
  for (int j = 0; j < 6; ++j) s << "," << 0.5;
  s << "," << static_cast<double>(i) << ",1,2,0.1,0.2,0.3" << extras << "\n";
  return s.str();
}

/// A log of the segments (rows, moving) in order; `kinds[i]` says whether row i moves.
std::string segmentedLog(const std::vector<std::pair<std::size_t, bool>>& segments, std::vector<bool>& kinds) {
  std::string text = std::string(kHeader) + "\n";
  for (const auto& [n, moving] : segments) {
    for (std::size_t k = 0; k < n; ++k) {
      text += row(kinds.size(), moving);
      kinds.push_back(moving);
    }
  }
  return text;
}

/// The rows the documented rule keeps: row i of class c is the j-th row of its class; it is kept
/// iff (j / block) % stride(c) == 0.
std::vector<std::size_t> keptByTheRule(const std::vector<bool>& moving, std::size_t block, std::size_t moving_stride,
                                       std::size_t still_stride) {
  std::vector<std::size_t> kept;
  std::size_t j_moving = 0, j_still = 0;
  for (std::size_t i = 0; i < moving.size(); ++i) {
    const std::size_t j = moving[i] ? j_moving++ : j_still++;
    if ((j / block) % (moving[i] ? moving_stride : still_stride) == 0) kept.push_back(i);
  }
  return kept;
}

/// The row numbers (the fx column) of the rows a log holds.
std::vector<std::size_t> rowsOf(const LogData& log) {
  std::vector<std::size_t> rows;
  for (const LogSample& s : log.samples) rows.push_back(static_cast<std::size_t>(s.wrench_S[0]));
  return rows;
}

/// The blocks and strides worked out by hand in a test, and the rows they keep.
struct Thinning {
  std::size_t block, moving_stride, still_stride, kept;
};

/// `t` has the hand-worked thinning, and its rows are those keptByTheRule gives for it.
void expectThinnedAs(const ThinnedLog& t, const std::vector<bool>& moving, const Thinning& expected) {
  EXPECT_EQ(t.block_rows, expected.block);
  EXPECT_EQ(t.moving_stride, expected.moving_stride);
  EXPECT_EQ(t.still_stride, expected.still_stride);
  EXPECT_EQ(t.log.samples.size(), expected.kept);
  EXPECT_EQ(rowsOf(t.log), keptByTheRule(moving, expected.block, expected.moving_stride, expected.still_stride));
}

TEST(StreamedLines, AreTheInMemoryCursorsLinesAtEveryChunkBoundary) {
  std::mt19937 rng(7);
  std::string text = "\xEF\xBB\xBF";  // a byte-order mark, dropped from the first line as readLogText drops it
  const char* pieces[] = {"a,b,c", "", "\r", "1.5,2,3", "#comment", "  ", "x\ry", "last"};
  for (int i = 0; i < 300; ++i) {
    text += pieces[rng() % 8];
    text += (rng() % 4 == 0) ? "\r\n" : "\n";
  }
  for (const bool final_newline : {true, false}) {
    const std::string body = final_newline ? text + "end\n" : text + "end";
    const std::string path = writeText("lines.csv", body);
    const std::string stripped = body.substr(3);
    for (const std::size_t chunk : {1, 2, 3, 5, 64, 4096}) {
      LineCursor whole{stripped};
      FileLineCursor streamed(path, 1 << 20, 64, chunk);
      std::string_view a, b;
      while (true) {
        const bool more = whole.next(a);
        ASSERT_EQ(streamed.next(b), more) << "chunk " << chunk << ", line " << whole.line_no;
        if (!more) break;
        ASSERT_EQ(std::string(a), std::string(b)) << "chunk " << chunk << ", line " << whole.line_no;
        ASSERT_EQ(whole.line_no, streamed.line_no);
      }
    }
  }
}

TEST(StreamedLines, ALineBeyondTheLimitIsRefusedNamingItsLine) {
  const std::string path = writeText("long_line.csv", "t,fx\n" + std::string(5000, '7') + "\n");
  FileLineCursor cur(path, 1 << 20, 1024, 256);
  std::string_view line;
  ASSERT_TRUE(cur.next(line));
  try {
    cur.next(line);
    FAIL() << "a 5000-character line passed a 1024-character limit";
  } catch (const DataError& e) {
    EXPECT_EQ(std::string(e.what()), path + ":2:1: line is longer than 1024 characters");
  }
  // A line of exactly the limit passes, with '\r\n', '\n' or no end; one character more does not.
  for (const char* end : {"\r\n", "\n", ""}) {
    const std::string ok = writeText("limit_line.csv", std::string(1024, '7') + end);
    FileLineCursor at_limit(ok, 1 << 20, 1024, 100);
    ASSERT_TRUE(at_limit.next(line));
    EXPECT_EQ(line.size(), 1024u);
    EXPECT_FALSE(at_limit.next(line));
    const std::string over = writeText("over_line.csv", "t\n" + std::string(1025, '7') + end);
    FileLineCursor past(over, 1 << 20, 1024, 100);
    ASSERT_TRUE(past.next(line));
    EXPECT_THROW(past.next(line), DataError) << "1025 characters ending in '" << end << "'";
  }
}

TEST(StreamedLines, AFileOfOnlyAByteOrderMarkHasNoLines) {
  for (const char* text : {"\xEF\xBB\xBF", "\xEF\xBB", ""}) {
    const std::string body(text);
    const std::string stripped = body.rfind("\xEF\xBB\xBF", 0) == 0 ? body.substr(3) : body;
    FileLineCursor cur(writeText("bom.csv", body), 1 << 20, 64, 1);
    LineCursor whole{stripped};
    std::string_view a, b;
    EXPECT_EQ(cur.next(a), whole.next(b)) << body.size() << " bytes";
  }
}

TEST(ThinnedLog, WithinTheBudgetItIsReadLogBitForBit) {
  std::string text = "# a comment\n" + std::string(kHeader) + ",robot_current\n";
  for (std::size_t i = 0; i < 3000; ++i) text += row(i, i % 700 < 400, "," + std::to_string(0.25 * i));
  const std::string path = writeText("within.csv", text);
  const LogData whole = readLog(path);
  for (const std::size_t max_rows : {3100, 100000}) {
    const ThinnedLog t = readLogThinned(path, LogKind::kMeasurement, {}, max_rows);
    EXPECT_FALSE(t.thinned());
    EXPECT_EQ(t.rows, 3000u);
    ASSERT_EQ(t.log.samples.size(), whole.samples.size());
    for (std::size_t i = 0; i < whole.samples.size(); ++i) {
      const LogSample& a = whole.samples[i];
      const LogSample& b = t.log.samples[i];
      ASSERT_TRUE(a.t == b.t && a.q == b.q && a.qd == b.qd && a.qdd == b.qdd && a.wrench_S == b.wrench_S) << i;
    }
    EXPECT_EQ(t.log.extra_names, whole.extra_names);
    EXPECT_EQ(t.log.extra_columns, whole.extra_columns);
  }
}

TEST(ThinnedLog, KeepsTheMotionWholeAndThinsTheRestInBlocksByItsOwnStride) {
  // 10,000 rows holding still and 800 moving, interleaved; --max-rows 2000 (no extra columns:
  // a budget of 2000 rows, blocks of 2000 / 16 = 125 rows). The still rows are 80 blocks; every
  // 8th keeps 10 blocks (1250 rows, with the motion 2050 > 2000), every 16th keeps 5 (625 rows,
  // 1425 in all): the still stride ends at 16 and the motion, never the larger class, is whole.
  std::vector<bool> moving;
  const std::string path =
      writeText("blocks.csv", segmentedLog({{5000, false}, {400, true}, {5000, false}, {400, true}}, moving));
  const ThinnedLog t = readLogThinned(path, LogKind::kMeasurement, {}, 2000);
  EXPECT_EQ(t.rows, 10800u);
  EXPECT_EQ(t.budget_rows, 2000u);
  EXPECT_EQ(t.moving_rows, 800u);
  EXPECT_EQ(t.still_rows, 10000u);
  expectThinnedAs(t, moving, {125, 1, 16, 1425});
}

TEST(ThinnedLog, AMotionLongerThanTheBudgetIsThinnedToo) {
  // 5000 moving rows, --max-rows 1000: blocks of 62 rows, 81 of them (the last holds 5000 - 80 * 62
  // = 40 rows). Every 4th block keeps blocks 0, 4, .., 80: 20 * 62 + 40 = 1280 > 1000; every 8th
  // keeps 0, 8, .., 80: 10 * 62 + 40 = 660.
  std::vector<bool> moving;
  const std::string path = writeText("motion.csv", segmentedLog({{5000, true}}, moving));
  expectThinnedAs(readLogThinned(path, LogKind::kMeasurement, {}, 1000), moving, {62, 8, 1, 660});
}

TEST(ThinnedLog, EveryRowIsCheckedAndItsStorageIsBoundedByTheBudget) {
  std::vector<bool> moving;
  std::string text = segmentedLog({{20000, true}}, moving);
  const ThinnedLog t = readLogThinned(writeText("bounded.csv", text), LogKind::kMeasurement, {}, 500);
  EXPECT_LE(t.log.samples.size(), 500u);
  EXPECT_LE(t.log.samples.capacity(), 501u);
  // A time that goes back on a row the thinning leaves out is still refused, naming its line.
  std::string back = text + row(19990, true);
  try {
    readLogThinned(writeText("back.csv", back), LogKind::kMeasurement, {}, 500);
    FAIL() << "a time going back was accepted";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("back.csv:20002:1: column 't'"), std::string::npos) << e.what();
  }
  // So is an implausible value on a row in the middle (row 10000, line 10002).
  std::string bad = text;
  const std::string good_row = row(10000, true);
  std::string bad_row = good_row;
  bad_row.replace(bad_row.find(",10000,1,2,"), 11, ",1e9,1,2,");
  bad.replace(bad.find(good_row), good_row.size(), bad_row);
  try {
    readLogThinned(writeText("bad.csv", bad), LogKind::kMeasurement, {}, 500);
    FAIL() << "an implausible fx was accepted";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.csv:10002:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("column 'fx'"), std::string::npos) << e.what();
  }
}

TEST(ThinnedLog, ADirectoryOrAMissingFileIsADataErrorNamingIt) {
  const std::string dir = ftid::test::binaryPath("/thinned_log_test_dir");
  ::mkdir(dir.c_str(), 0755);
  for (const std::string& path : {dir, dir + "/none.csv"}) {
    try {
      readLogThinned(path, LogKind::kMeasurement, {}, 100);
      FAIL() << path << " was read";
    } catch (const DataError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(path + ": cannot ", 0), 0u) << e.what();
    }
  }
}

TEST(ThinnedLog, ExtraColumnsLowerTheRowBudgetByTheirBytes) {
  EXPECT_EQ(rowBudget(1000, 0), 1000u);
  EXPECT_EQ(rowBudget(1000, 125), 500u);  // 125 columns of 16 bytes: as much as the row itself
  EXPECT_EQ(rowBudget(1, 1000), 2u);  // the first row of each class is always kept
  std::string header = kHeader;
  std::string extras;
  for (int k = 0; k < 125; ++k) {
    header += ",x" + std::to_string(k);
    extras += "," + std::to_string(k);
  }
  // A last extra column carries the row number: the thinning keeps each row's extras with it.
  header += ",row";
  std::string text = header + "\n";
  for (std::size_t i = 0; i < 3000; ++i) text += row(i, true, extras + "," + std::to_string(i));
  const ThinnedLog t = readLogThinned(writeText("extras.csv", text), LogKind::kMeasurement, {}, 1000);
  EXPECT_EQ(t.budget_rows, rowBudget(1000, 126));
  EXPECT_TRUE(t.thinned());
  EXPECT_LE(t.log.samples.size(), t.budget_rows);
  for (const auto& c : t.log.extra_columns) ASSERT_EQ(c.size(), t.log.samples.size());
  EXPECT_EQ(t.log.extra_columns[7][3], 7.0);
  for (std::size_t j = 0; j < t.log.samples.size(); ++j) {
    ASSERT_EQ(t.log.extra_columns[125][j], t.log.samples[j].wrench_S[0]) << j;
  }
}

TEST(ThinnedLog, TheSmallestBudgetKeepsTheFirstRowOfEachClass) {
  // Rows alternate between moving and holding still; --max-rows 1 is a budget of 2 rows, blocks of 1.
  std::vector<bool> moving;
  std::vector<std::pair<std::size_t, bool>> segments;
  for (int k = 0; k < 50; ++k) segments.emplace_back(1, k % 2 == 0);
  const ThinnedLog t = readLogThinned(writeText("smallest.csv", segmentedLog(segments, moving)), LogKind::kMeasurement, {}, 1);
  EXPECT_EQ(t.budget_rows, 2u);
  EXPECT_EQ(rowsOf(t.log), (std::vector<std::size_t>{0, 1}));
  // Blocks that do not fit twice in the budget could never be thinned enough: refused up front.
  EXPECT_THROW(RowThinner(2, 5), std::invalid_argument);
  EXPECT_NO_THROW(RowThinner(10, 5));
}

TEST(ThinnedLog, APoseLogBeyondTheBudgetIsRefusedWithItsRows) {
  std::string text = "t,px,py,pz,qx,qy,qz,qw,fx,fy,fz,tx,ty,tz\n";
  for (int i = 0; i < 3000; ++i) text += std::to_string(0.01 * i) + ",0,0,0,0,0,0,1,1,2,3,0.1,0.2,0.3\n";
  const std::string path = writeText("pose.csv", text);
  // Its seven pose columns are extra columns: 4000 rows' budget holds 4000 * 2000 / 2112 = 3787 rows.
  EXPECT_EQ(readLogThinned(path, LogKind::kMeasurement, {}, 4000).log.samples.size(), 3000u);
  try {
    readLogThinned(path, LogKind::kMeasurement, {}, 1000);
    FAIL() << "a pose log was thinned";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find(path + ": 3000 data rows, more than --max-rows 1000 (946 rows with its "
                                             "extra columns) allows"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("about 6 MB of memory"), std::string::npos) << e.what();
  }
}

TEST(ThinnedLog, ReadInputSaysHowItThinnedAndReadsEveryRowWithoutABudget) {
  std::vector<bool> moving;
  const std::string path =
      writeText("input.csv", segmentedLog({{5000, false}, {400, true}, {5000, false}, {400, true}}, moving));
  InputOptions options;
  options.max_rows = 2000;
  const InputLog thinned = readInput(path, options);
  EXPECT_EQ(thinned.log.samples.size(), 1425u);
  EXPECT_EQ(thinned.thinned_note,
            path + ": 10800 data rows (800 moving, 10000 holding still); every row of the motion and every 16th "
                   "block of 125 rows of the rest are used (1425 rows) to stay within --max-rows 2000 (memory; "
                   "docs/log-format.md \"Limits\"). Every row was checked; the statistics are those of the rows "
                   "used");
  ASSERT_FALSE(thinned.notes.empty());
  EXPECT_EQ(thinned.notes.front(), thinned.thinned_note);
  const InputLog whole = readInput(path, {});
  EXPECT_EQ(whole.log.samples.size(), 10800u);
  EXPECT_TRUE(whole.thinned_note.empty());
  // A UR recording is recognised from its header whatever the budget (and read whole).
  EXPECT_TRUE(isUrRecordFile(writeText("ur.txt", "\xEF\xBB\xBF# x\ntimestamp actual_q_0 actual_q_1\n1 2 3\n")));
  EXPECT_FALSE(isUrRecordFile(path));
}

}  // namespace
}  // namespace ftid::logio
