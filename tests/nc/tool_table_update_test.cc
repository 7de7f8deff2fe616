// The one tool-table writer: every change checked against the table, the machine's limit and
// the value it was decided on; all written or none; each logged before and after.

#include "mlp/nc/tool_table_update.h"

#include "mlp/base/files.h"
#include "mlp/nc/tool_table.h"

#include <filesystem>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

namespace mlp::nc {
namespace {

namespace fs = std::filesystem;

const std::string kTable =
    "; mill tool table\n"
    "T1 P1 Z+120.5 D10.0 ;10 mm end mill\n"
    "T2 P2 Z95.25 D6 ;6 mm drill\n";

// The values a table holds are read back to this (LinuxCNC's files carry 4 to 6 decimals).
constexpr double kReadBackMm = 1e-9;

class ToolTableUpdateTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("mlp_nc_update_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    base::WriteFileAtomically(Table(), kTable);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Table() const { return (dir_ / "tool.tbl").string(); }
  std::string Log() const { return (dir_ / "mlp-tool-changes.csv").string(); }
  fs::path dir_;
};

TEST_F(ToolTableUpdateTest, WritesEveryChangeAndLogsBeforeAndAfter) {
  ToolUpdate t1{1, "EM10", 120.4987, 9.9962, 120.5, 10.0};
  ToolUpdate t2{2, "DR6, spare", std::nullopt, 5.998, std::nullopt, std::nullopt};
  const auto r = UpdateToolTable(Table(), {t1, t2}, {}, "job 7 on mill-1");
  EXPECT_TRUE(r.log_error.empty()) << r.log_error;
  EXPECT_EQ(r.log_file, Log());
  ASSERT_EQ(r.changes.size(), 2u);
  EXPECT_NEAR(r.changes[0].length_before_mm, 120.5, kReadBackMm);
  EXPECT_NEAR(r.changes[1].length_after_mm, 95.25, kReadBackMm);  // not asked: unchanged
  const ToolTable after = LoadToolTable(Table());
  EXPECT_NEAR(after.Find(1)->Get('Z'), 120.4987, kReadBackMm);
  EXPECT_NEAR(after.Find(1)->Get('D'), 9.9962, kReadBackMm);
  EXPECT_NEAR(after.Find(2)->Get('Z'), 95.25, kReadBackMm);
  EXPECT_NEAR(after.Find(2)->Get('D'), 5.998, kReadBackMm);
  EXPECT_EQ(after.Find(2)->comment, "6 mm drill");
  std::istringstream log(base::ReadFile(Log()));
  std::string header, line1, line2, rest;
  std::getline(log, header), std::getline(log, line1), std::getline(log, line2);
  EXPECT_EQ(header,
            "time_utc,tool,tool_id,length_before_mm,length_after_mm,diameter_before_mm,"
            "diameter_after_mm,source");
  EXPECT_NE(line1.find(",1,EM10,120.50000,120.49870,10.00000,9.99620,job 7 on mill-1"),
            std::string::npos)
      << line1;
  EXPECT_NE(line2.find(",2,\"DR6, spare\",95.25000,95.25000,6.00000,5.99800,"), std::string::npos)
      << line2;  // a comma in a field is quoted (RFC 4180)
  EXPECT_FALSE(std::getline(log, rest));
}

TEST_F(ToolTableUpdateTest, ARefusalWritesNothingAtAll) {
  const auto refused = [&](const std::vector<ToolUpdate>& updates, const ToolChangeLimits& limits,
                           const std::string& why) {
    try {
      UpdateToolTable(Table(), updates, limits, "test");
      ADD_FAILURE() << "not refused: " << why;
    } catch (const ToolTableError& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
    EXPECT_EQ(base::ReadFile(Table()), kTable) << why;
    EXPECT_FALSE(fs::is_regular_file(Log())) << why;  // no log line either
  };
  const ToolUpdate good{1, "", 120.45, std::nullopt, std::nullopt, std::nullopt};
  // The second tool's problem stops the first tool's good change too.
  refused({good, {7, "", 100.0, std::nullopt, std::nullopt, std::nullopt}}, {}, "T7 is not in");
  refused({good, {2, "", 96.0, std::nullopt, std::nullopt, std::nullopt}}, {}, "beyond");
  refused({good, {2, "", std::nullopt, 6.3, std::nullopt, std::nullopt}},
          {.max_length_change_mm = 1.0, .max_diameter_change_mm = 0.2}, "beyond");
  refused({good, {2, "", 95.3, std::nullopt, 95.2, std::nullopt}}, {}, "changed in between");
  refused(
      {good,
       {2, "", std::numeric_limits<double>::quiet_NaN(), std::nullopt, std::nullopt, std::nullopt}},
      {}, "not finite");
  refused({good, good}, {}, "named twice");
  EXPECT_THROW(UpdateToolTable(Table(), {{2, "", 96.0, std::nullopt, std::nullopt, std::nullopt}},
                               {}, "test"),
               ToolChangeRefused);  // a refusal of the value, not of the input
  EXPECT_THROW(UpdateToolTable((dir_ / "absent.tbl").string(), {good}, {}, "test"), ToolTableError);
  // A log that cannot be appended to is found before the table is touched.
  fs::create_directories(Log());  // a folder where the log should be
  refused({good}, {}, "change log");
}

// An EDM electrode put back after re-clamping: its X, Y and C offsets with its length, each
// checked as Z is (C against the rotary limit in degrees), logged after the source.
TEST_F(ToolTableUpdateTest, OffsetWordsAcrossTheSpindleAndTheTurn) {
  ToolUpdate e{2, "E3", 95.235, std::nullopt, 95.25, std::nullopt};
  e.offsets = {{'X', -0.03}, {'Y', 0.02}, {'C', -0.4}};
  e.offsets_before = {{'X', 0.0}, {'Y', 0.0}, {'C', 0.0}};
  const auto r = UpdateToolTable(Table(), {e}, {}, "job 9 on edm-1");
  ASSERT_EQ(r.changes.size(), 1u);
  EXPECT_NEAR(r.changes[0].offsets.at('C').second, -0.4, kReadBackMm);
  const ToolTable after = LoadToolTable(Table());
  EXPECT_NEAR(after.Find(2)->Get('X'), -0.03, kReadBackMm);
  EXPECT_NEAR(after.Find(2)->Get('Y'), 0.02, kReadBackMm);
  EXPECT_NEAR(after.Find(2)->Get('C'), -0.4, kReadBackMm);
  EXPECT_NEAR(after.Find(2)->Get('Z'), 95.235, kReadBackMm);
  EXPECT_NE(base::ReadFile(Log()).find("job 9 on edm-1; C 0.00000 -> -0.40000; X 0.00000 -> "
                                       "-0.03000; Y 0.00000 -> 0.02000"),
            std::string::npos)
      << base::ReadFile(Log());
  // Beyond the rotary limit, decided on a stale value, or not an offset word: nothing written.
  const std::string table = base::ReadFile(Table());
  ToolUpdate turned{2, "E3", std::nullopt, std::nullopt, std::nullopt, std::nullopt};
  turned.offsets = {{'C', 1.0}};
  EXPECT_THROW(UpdateToolTable(Table(), {turned}, {.max_rotation_change_deg = 1.0}, "t"),
               ToolChangeRefused);
  turned.offsets = {{'C', 0.0}}, turned.offsets_before = {{'C', 0.0}};
  EXPECT_THROW(UpdateToolTable(Table(), {turned}, {}, "t"), ToolChangeRefused);
  turned.offsets = {{'Q', 1.0}}, turned.offsets_before = {};
  EXPECT_THROW(UpdateToolTable(Table(), {turned}, {}, "t"), ToolTableError);
  EXPECT_EQ(base::ReadFile(Table()), table);
}

TEST_F(ToolTableUpdateTest, TheLogKeepsEveryUpdateInOrder) {
  for (int i = 1; i <= 3; ++i)
    UpdateToolTable(Table(),
                    {{1, "EM10", 120.5 - 0.01 * i, std::nullopt, std::nullopt, std::nullopt}}, {},
                    "run " + std::to_string(i));
  std::istringstream log(base::ReadFile(Log()));
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(log, line)) lines.push_back(line);
  ASSERT_EQ(lines.size(), 4u);  // the header once
  EXPECT_NE(lines[1].find("120.50000,120.49000"), std::string::npos) << lines[1];
  EXPECT_NE(lines[3].find("120.48000,120.47000,10.00000,10.00000,run 3"), std::string::npos)
      << lines[3];
}

}  // namespace
}  // namespace mlp::nc

namespace mlp::nc {
namespace {

// Issue 48, item 5: two machines' lanes of one host configured on one tool table. Each lane
// reads, changes and writes the table; with one temporary name per process one lane's rename
// took the other's file away ("cannot replace": 8 of 160 writes lost), and without a lock a
// lane's write replaced the table the other had read, dropping its change without a word.
TEST_F(ToolTableUpdateTest, TwoWritersOfOneTableLoseNoChange) {
  constexpr int kWritesEach = 80;
  constexpr double kStepMm = 0.001;
  const auto lane = [&](int tool, std::vector<std::string>* errors) {
    for (int k = 0; k < kWritesEach; ++k) {
      try {
        const double now = LoadToolTable(Table()).Find(tool)->Get('Z');
        ToolUpdate u{tool, "", std::nullopt, std::nullopt, std::nullopt, std::nullopt};
        u.length_mm = now + kStepMm;
        // Decided on `now`: the other lane's writes between the read and this write leave this
        // tool's Z as it was, so the stale check passes; only a lost write would show.
        u.length_before_mm = now;
        UpdateToolTable(Table(), {u}, {}, "lane of T" + std::to_string(tool));
      } catch (const std::exception& e) {
        errors->push_back(e.what());
      }
    }
  };
  std::vector<std::string> errors1, errors2;
  std::thread a(lane, 1, &errors1), b(lane, 2, &errors2);
  a.join(), b.join();
  EXPECT_TRUE(errors1.empty()) << errors1.front();
  EXPECT_TRUE(errors2.empty()) << errors2.front();
  const ToolTable after = LoadToolTable(Table());
  EXPECT_NEAR(after.Find(1)->Get('Z'), 120.5 + kWritesEach * kStepMm, kReadBackMm);
  EXPECT_NEAR(after.Find(2)->Get('Z'), 95.25 + kWritesEach * kStepMm, kReadBackMm);
  std::size_t temporaries = 0;
  for (const auto& e : fs::directory_iterator(dir_))
    temporaries += base::IsTemporaryName(e.path().filename().string());
  EXPECT_EQ(temporaries, 0u);
}

// LinuxCNC's register rules, one place (issue 53): a radius is half of D, a wear change moves
// the geometry value (LinuxCNC has none), the restart's check reads the same registers back.
TEST(ToolTableRules, AChangeIsResolvedAgainstTheTableAndWrittenAsItsWords) {
  const ToolTable table = ToolTable::Parse(kTable, "tool.tbl");
  std::string note;
  const ToolOffsetChange r =
      ResolveOnTable(table, "tool.tbl", 1, ToolRegister::kRadiusGeometry, -0.003, &note);
  EXPECT_TRUE(note.empty());
  EXPECT_FALSE(r.incremental);
  EXPECT_NEAR(r.before_mm, 5.0, kReadBackMm);  // D10
  EXPECT_NEAR(r.after_mm, 4.997, kReadBackMm);
  const ToolOffsetChange l =
      ResolveOnTable(table, "tool.tbl", 2, ToolRegister::kLengthWear, 0.01, &note);
  EXPECT_EQ(l.reg, ToolRegister::kLengthGeometry);
  EXPECT_NE(note.find("no wear registers"), std::string::npos) << note;
  EXPECT_NEAR(l.after_mm, 95.26, kReadBackMm);
  EXPECT_THROW(ResolveOnTable(table, "tool.tbl", 9, ToolRegister::kLengthGeometry, 0.0, &note),
               ToolTableError);

  const std::vector<ToolUpdate> u = ToolUpdatesOf({r, l});
  ASSERT_EQ(u.size(), 2u);
  EXPECT_NEAR(*u[0].diameter_mm, 9.994, kReadBackMm);  // twice the radius
  EXPECT_NEAR(*u[0].diameter_before_mm, 10.0, kReadBackMm);
  EXPECT_FALSE(u[0].length_mm.has_value());
  EXPECT_NEAR(*u[1].length_mm, 95.26, kReadBackMm);
}

TEST(ToolTableRules, ARestartSeesAWriteInTheTableOnlyWhenEveryRegisterHoldsItsValue) {
  ToolTable table = ToolTable::Parse(kTable, "tool.tbl");
  const ToolOffsetChange radius{1, ToolRegister::kRadiusGeometry, 5.0, 4.997, false};
  const ToolOffsetChange length{1, ToolRegister::kLengthGeometry, 120.5, 120.49, false};
  EXPECT_FALSE(TableHolds(table, {radius, length}));
  table.Set(1, 'D', 9.994);
  EXPECT_FALSE(TableHolds(table, {radius, length}));  // half written is not written
  table.Set(1, 'Z', 120.49);
  EXPECT_TRUE(TableHolds(table, {radius, length}));
  ToolOffsetChange increment = radius;
  increment.incremental = true;  // a change the host cannot read back
  EXPECT_FALSE(TableHolds(table, {increment}));
  EXPECT_FALSE(TableHolds(table, {{7, ToolRegister::kLengthGeometry, 0, 1, false}}));
}

}  // namespace
}  // namespace mlp::nc
