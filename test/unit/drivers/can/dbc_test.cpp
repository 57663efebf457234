// DBC parser: the default sensor file, the statement subset, and error messages with file:line.
#include <gtest/gtest.h>

#include <string>

#include "ftid/common/error.hpp"
#include "ftid/drivers/can/dbc.hpp"
#include "test_paths.hpp"

namespace ftid::drivers::can {
namespace {

// Expects parseDbc(text) to throw a DataError whose message contains every fragment.
void expectDbcError(const std::string& text, std::initializer_list<std::string> fragments) {
  try {
    parseDbc(text, "t.dbc");
    FAIL() << "no error for:\n" << text;
  } catch (const DataError& e) {
    const std::string msg = e.what();
    for (const auto& f : fragments) EXPECT_NE(msg.find(f), std::string::npos) << msg;
  }
}

TEST(Dbc, DefaultSensorFileDescribesSixMessages) {
  const DbcDatabase db = loadDbc(ftid::test::sourcePath("/config/ftsensor.dbc"));
  EXPECT_EQ(db.version, "ftid-ftsensor-1.0");
  ASSERT_EQ(db.messages.size(), 6u);
  const DbcMessage* force = db.findMessage("FT_Force");
  ASSERT_NE(force, nullptr);
  EXPECT_EQ(force->id, 0x1A0u);
  EXPECT_FALSE(force->extended);
  EXPECT_EQ(force->dlc, 8);
  EXPECT_EQ(force->transmitter, "FTSENSOR");
  const DbcSignal* fz = force->findSignal("Fz");
  ASSERT_NE(fz, nullptr);
  EXPECT_EQ(fz->start_bit, 40);
  EXPECT_EQ(fz->length, 16);
  EXPECT_EQ(fz->byte_order, ByteOrder::kLittleEndian);
  EXPECT_TRUE(fz->is_signed);
  EXPECT_DOUBLE_EQ(fz->factor, 0.05);
  EXPECT_DOUBLE_EQ(fz->minimum, -500.0);
  EXPECT_DOUBLE_EQ(fz->maximum, 500.0);
  EXPECT_EQ(fz->unit, "N");
  ASSERT_EQ(fz->receivers.size(), 1u);
  EXPECT_EQ(fz->receivers[0], "FTIDD");
  const DbcMessage* status = db.findMessage(0x1A5, false);
  ASSERT_NE(status, nullptr);
  EXPECT_EQ(status->dlc, 5);
  const DbcSignal* temp = status->findSignal("Temperature");
  ASSERT_NE(temp, nullptr);
  EXPECT_EQ(temp->byte_order, ByteOrder::kBigEndian);
  EXPECT_EQ(temp->unit, "degC");
  EXPECT_NE(temp->comment.find("0.01 degC per bit"), std::string::npos);
  EXPECT_NE(force->comment.find("0.05 N per bit"), std::string::npos);
  for (const auto& m : db.messages) EXPECT_NE(m.findSignal("Counter"), nullptr) << m.name;
}

TEST(Dbc, ParsesExtendedIdsSkipsUnparsedStatementsAndMultiLineComments) {
  const std::string text =
      "VERSION \"\"\n"
      "NS_ :\n\tCM_\n\tVAL_\n\n"
      "BS_:\n"
      "BU_: A B\n"
      "VAL_TABLE_ Mode 1 \"on\" 0 \"off\" ;\n"
      "BO_ 2147484276 Ext: 4 A\n"  // 0x80000000 | 0x274
      " SG_ Mode : 0|1@1+ (1,0) [0|1] \"\" B,A\n"
      " SG_ Val : 8|12@1- (0.5,-3) [0|0] \"bar\" Vector__XXX\n"
      "BO_ 3221225472 VECTOR__INDEPENDENT_SIG_MSG: 0 Vector__XXX\n"
      " SG_ Orphan : 0|8@1+ (1,0) [0|0] \"\" Vector__XXX\n"
      "CM_ SG_ 2147484276 Val \"a comment\n"
      "spanning \\\"two\\\" lines\";\n"
      "CM_ \"database comment\";\n"
      "VAL_ 2147484276 Mode 1 \"on\" 0 \"off\" ;\n"
      "BA_DEF_ BO_ \"GenMsgCycleTime\" INT 0\n"
      "  10000;\n"
      "SIG_VALTYPE_ 2147484276 Val : 0;\n";
  const DbcDatabase db = parseDbc(text, "x.dbc");
  ASSERT_EQ(db.messages.size(), 1u);
  const DbcMessage& m = db.messages[0];
  EXPECT_TRUE(m.extended);
  EXPECT_EQ(m.id, 0x274u);
  EXPECT_EQ(db.findMessage(0x274, true), &m);
  EXPECT_EQ(db.findMessage(0x274, false), nullptr);
  ASSERT_EQ(m.signals.size(), 2u);
  EXPECT_EQ(m.signals[0].receivers.size(), 2u);
  EXPECT_DOUBLE_EQ(m.signals[1].offset, -3.0);
  EXPECT_FALSE(m.signals[1].hasRange());
  EXPECT_EQ(m.signals[1].comment, "a comment\nspanning \"two\" lines");
  EXPECT_EQ(m.signals[1].line, 11);
  EXPECT_EQ(db.nodes.size(), 2u);
}

TEST(Dbc, ErrorsNameFileAndLine) {
  expectDbcError("BO_ 1 M: 8 A\n SG_ S : 0|8@2+ (1,0) [0|0] \"\" A\n",
                 {"t.dbc:2:", "byte order"});
  expectDbcError("BO_ 1 M: 8 A\n SG_ S : 0|8@1+ (1,0 [0|0] \"\" A\n", {"t.dbc:2:", "')'"});
  expectDbcError("BO_ 1 M: 8 A\n SG_ S : 0|8@1+ (1,0) [0|0] \"unit A\n",
                 {"t.dbc:2:", "unterminated"});
  expectDbcError("\n\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" A\n", {"t.dbc:3:", "no BO_"});
  expectDbcError("BO_ 1 M: 2 A\n SG_ S : 8|16@1+ (1,0) [0|0] \"\" A\n",
                 {"t.dbc:2:", "does not fit", "'M'"});
  expectDbcError("BO_ 1 M: 8 A\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" A\n"
                 " SG_ T : 7|4@1+ (1,0) [0|0] \"\" A\n",
                 {"t.dbc:3:", "overlaps signal 'S'", "bit 7"});
  expectDbcError("BO_ 1 M: 8 A\n SG_ S M : 0|8@1+ (1,0) [0|0] \"\" A\n",
                 {"t.dbc:2:", "multiplexed"});
  expectDbcError("BO_ 1 M: 8 A\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" A\nBO_ 1 N: 8 A\n",
                 {"t.dbc:3:", "already used"});
  expectDbcError("BO_ 2048 M: 8 A\n", {"t.dbc:1:", "11-bit"});
  expectDbcError("BO_ 1 M: 64 A\n", {"t.dbc:1:", "classic CAN"});
  expectDbcError("BO_ 1 M: 8 A\n SG_ S : 0|32@1- (1,0) [0|0] \"\" A\n"
                 "SIG_VALTYPE_ 1 S : 1;\n",
                 {"t.dbc:3:", "float"});
  expectDbcError("BO_ 1 M: 8 A\n SG_ S : 0|8@1+ (0,0) [0|0] \"\" A\n", {"t.dbc:2:", "factor 0"});
  expectDbcError("BO_ 1 M: 8 A\n\nFOO_ bar;\n", {"t.dbc:3:", "unknown DBC statement 'FOO_'"});
  expectDbcError("BO_ 1 M: 8 A\n SG_ S : 0|8@1+ (1,0) [5|1] \"\" A\n", {"t.dbc:2:", "minimum"});
}

TEST(Dbc, MissingFileIsNamed) {
  try {
    loadDbc("/nonexistent/sensor.dbc");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/sensor.dbc"), std::string::npos);
  }
}

TEST(Dbc, MotorolaSignalMustFitToo) {
  // Motorola start 7, 16 bits: bytes 0-1 -> fits a 2-byte message; start 15 needs 3 bytes.
  EXPECT_NO_THROW(parseDbc("BO_ 1 M: 2 A\n SG_ S : 7|16@0+ (1,0) [0|0] \"\" A\n", "t.dbc"));
  expectDbcError("BO_ 1 M: 2 A\n SG_ S : 15|16@0+ (1,0) [0|0] \"\" A\n", {"t.dbc:2:", "fit"});
}

}  // namespace
}  // namespace ftid::drivers::can
