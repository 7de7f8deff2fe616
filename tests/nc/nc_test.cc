// Controller adapters' text: the LinuxCNC tool table read and written keeping what is not ours,
// and offset changes as NC code for LinuxCNC and Fanuc / Haas / Syntec style controls.

#include "mlp/nc/nc_output.h"
#include "mlp/nc/tool_table.h"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <sys/stat.h>

namespace mlp::nc {
namespace {

namespace fs = std::filesystem;

const std::string kTable =
    "; mill tool table, edited by hand\n"
    "T1 P1 Z+120.5 D10.0 ;10 mm end mill\n"
    "T2 P2 X0.1 Z95.25 D6 I0 J0 Q0 ;6 mm drill; spare in drawer 3\n"
    "\n"
    "T99 P99 Z0.0 D0.0 ;the probe\n";

std::string ReadAll(const fs::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(ToolTable, ReadsLinuxCncLines) {
  const ToolTable t = ToolTable::Parse(kTable, "tool.tbl");
  ASSERT_EQ(t.Tools().size(), 3u);
  const auto t2 = t.Find(2);
  ASSERT_TRUE(t2);
  EXPECT_EQ(t2->pocket, 2);
  EXPECT_DOUBLE_EQ(t2->Get('Z'), 95.25);
  EXPECT_DOUBLE_EQ(t2->Get('X'), 0.1);
  EXPECT_DOUBLE_EQ(t2->Get('Y'), 0.0);  // absent reads as 0, as LinuxCNC does
  EXPECT_EQ(t2->comment, "6 mm drill; spare in drawer 3");
  EXPECT_FALSE(t.Find(3));
  EXPECT_EQ(t.Text(), kTable);  // nothing changed: byte for byte
}

TEST(ToolTable, ChangesOnlyTheWordsItOwns) {
  ToolTable t = ToolTable::Parse(kTable, "tool.tbl");
  EXPECT_DOUBLE_EQ(t.Set(1, 'D', 9.9968), 10.0);
  EXPECT_DOUBLE_EQ(t.Set(2, 'Y', -0.02), 0.0);  // a word the line did not have
  const std::string text = t.Text();
  EXPECT_NE(text.find("T1 P1 Z+120.5 D9.9968 ;10 mm end mill\n"), std::string::npos) << text;
  EXPECT_NE(text.find("T2 P2 X0.1 Z95.25 D6 I0 J0 Q0 Y-0.02 ;6 mm drill; spare in drawer 3\n"),
            std::string::npos)
      << text;
  // Every other line as it was.
  EXPECT_EQ(text.substr(0, text.find("T1")), "; mill tool table, edited by hand\n");
  EXPECT_NE(text.find("\n\nT99 P99 Z0.0 D0.0 ;the probe\n"), std::string::npos);
  const ToolTable again = ToolTable::Parse(text, "round trip");
  EXPECT_DOUBLE_EQ(again.Find(1)->Get('D'), 9.9968);
  EXPECT_DOUBLE_EQ(again.Find(1)->Get('Z'), 120.5);
}

TEST(ToolTable, RefusesWhatLinuxCncWouldNotRead) {
  const auto error = [](const std::string& text) {
    try {
      ToolTable::Parse(text, "t.tbl");
    } catch (const ToolTableError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(error("T1 Z1\n").find("line 1: a tool line needs T and P"), std::string::npos);
  EXPECT_NE(error("T1 P1\nT1 P2\n").find("line 2: tool T1 is listed twice"), std::string::npos);
  EXPECT_NE(error("T1 P1 K3\n").find("unknown word 'K3'"), std::string::npos);
  EXPECT_NE(error("T1 P1 Z1.2.3\n").find("not a letter followed by a number"), std::string::npos);
  EXPECT_NE(error("T1 P1 Znan\n").find("finite"), std::string::npos);
  EXPECT_NE(error("T1.5 P1\n").find("whole number"), std::string::npos);
  EXPECT_NE(error("T1 P1 Z1 Z2\n").find("twice"), std::string::npos);
  EXPECT_NE(error("T1 P1 D-3\n").find("diameter"), std::string::npos);
  ToolTable t = ToolTable::Parse(kTable, "t");
  EXPECT_THROW(t.Set(7, 'Z', 1.0), ToolTableError);           // no such tool
  EXPECT_THROW(t.Set(1, 'K', 1.0), ToolTableError);           // no such word
  EXPECT_THROW(t.Set(1, 'Z', std::nan("")), ToolTableError);  // no NaN into a machine
  EXPECT_THROW(t.Set(1, 'Q', 2.5), ToolTableError);           // orientation is whole
  EXPECT_EQ(t.Text(), kTable);                                // refusals changed nothing
}

TEST(ToolTable, SavesAtomicallyKeepingPermissions) {
  const fs::path dir = fs::temp_directory_path() / "mlp_nc_tool_table";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path path = dir / "tool.tbl";
  std::ofstream(path) << kTable;
  ::chmod(path.c_str(), 0640);
  ToolTable t = LoadToolTable(path.string());
  t.Set(99, 'Z', 210.125);
  SaveToolTable(t, path.string());
  EXPECT_EQ(ReadAll(path), t.Text());
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0640u);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1)
      << "no temporary file left";
  // A folder that cannot be written: the old file stays as it was.
  const fs::path ro = dir / "ro";
  fs::create_directories(ro);
  std::ofstream(ro / "tool.tbl") << kTable;
  if (::geteuid() != 0) {  // root ignores directory permissions; the next check covers root
    ::chmod(ro.c_str(), 0555);
    EXPECT_THROW(SaveToolTable(t, (ro / "tool.tbl").string()), ToolTableError);
    ::chmod(ro.c_str(), 0755);
  }
  EXPECT_THROW(SaveToolTable(t, (dir / "missing" / "tool.tbl").string()), ToolTableError);
  EXPECT_EQ(ReadAll(ro / "tool.tbl"), kTable);
  EXPECT_THROW(LoadToolTable((dir / "absent.tbl").string()), ToolTableError);
}

NcResult BoreResult() {
  NcResult r;
  r.header = "mlprobe job 42: bore B1";
  r.tools.push_back({12, ToolRegister::kRadiusWear, 0.0, -0.0031});
  r.tools.push_back({12, ToolRegister::kLengthGeometry, 101.2, 101.2046});
  r.work.push_back({1, {0, 0, 0}, {250.0012, -120.5, -310.25}, std::nullopt, std::nullopt});
  return r;
}

TEST(NcOutput, LinuxCncSubroutine) {
  NcResult r = BoreResult();
  r.tools[0].reg = ToolRegister::kRadiusGeometry;
  r.tools[0].after_mm = 4.9969;
  r.work[0].rotation_after_deg = 0.0125;
  r.named["diameter"] = 60.0123;
  EXPECT_EQ(LinuxCncSubroutine("mlp_result", r),
            "o<mlp_result> sub\n"
            "(mlprobe job 42: bore B1)\n"
            "G10 L1 P12 R4.9969\n"
            "G10 L1 P12 Z101.2046\n"
            "G10 L2 P1 X250.0012 Y-120.5000 Z-310.2500 R0.0125\n"
            "#<_mlp_diameter> = 60.0123\n"
            "o<mlp_result> endsub\n"
            "M2\n");
  EXPECT_THROW(LinuxCncSubroutine("mlp_result", BoreResult()), NcOutputError);  // wear
  r.named["Bad Name"] = 1;
  EXPECT_THROW(LinuxCncSubroutine("mlp_result", r), NcOutputError);
  EXPECT_EQ(WorkOffsetName(Dialect::kLinuxCnc, 9), "G59.3");
  r.named.clear();
  r.header = "a (nested) comment";  // parentheses would end the NC comment early
  EXPECT_NE(LinuxCncSubroutine("mlp_result", r).find("\n(a  nested  comment)\n"),
            std::string::npos);
  EXPECT_THROW(WorkOffsetName(Dialect::kLinuxCnc, 10), NcOutputError);
}

// An EDM electrode's offsets across the spindle and its turn (re-clamped): LinuxCNC's G10 L1
// sets them; a Fanuc-style control has no such register and is refused.
TEST(NcOutput, ToolOffsetsAcrossTheSpindleAndTheTurn) {
  NcResult r;
  r.header = "mlprobe job 9: tool E3";
  r.tools.push_back({30, ToolRegister::kOffsetX, 0.0, -0.03});
  r.tools.push_back({30, ToolRegister::kOffsetC, 0.0, -0.4});
  EXPECT_EQ(LinuxCncSubroutine("mlp_result", r),
            "o<mlp_result> sub\n"
            "(mlprobe job 9: tool E3)\n"
            "G10 L1 P30 X-0.0300\n"
            "G10 L1 P30 C-0.4000\n"
            "o<mlp_result> endsub\n"
            "M2\n");
  EXPECT_EQ(ToString(ToolRegister::kOffsetY), "offset Y");
  EXPECT_EQ(OffsetWord(ToolRegister::kOffsetY), 'Y');
  EXPECT_EQ(OffsetWord(ToolRegister::kLengthGeometry), 0);
  EXPECT_THROW(FanucStyleSnippet(FanucMap(), r), NcOutputError);
}

TEST(NcOutput, FanucG10AndVariables) {
  NcMap fanuc = FanucMap();
  EXPECT_EQ(FanucStyleSnippet(fanuc, BoreResult()),
            "(mlprobe job 42: bore B1)\n"
            "G90\n"
            "G10 L13 P12 R-0.0031\n"
            "G10 L10 P12 R101.2046\n"
            "G10 L2 P1 X250.0012 Y-120.5000 Z-310.2500\n");
  fanuc.use_variables = true;
  EXPECT_EQ(FanucStyleSnippet(fanuc, BoreResult()),
            "(mlprobe job 42: bore B1)\n"
            "G90\n"
            "#12012 = -0.0031\n"
            "#11012 = 101.2046\n"
            "#5221 = 250.0012\n#5222 = -120.5000\n#5223 = -310.2500\n");
  NcResult extended = BoreResult();
  extended.tools.clear();
  extended.work[0].index = 6 + 3;  // G54.1 P3
  EXPECT_NE(FanucStyleSnippet(fanuc, extended).find("#7041 = 250.0012"), std::string::npos);
  fanuc.use_variables = false;
  EXPECT_NE(FanucStyleSnippet(fanuc, extended).find("G10 L20 P3 X250.0012"), std::string::npos);
  EXPECT_EQ(WorkOffsetName(Dialect::kFanuc, 9), "G54.1 P3");
}

TEST(NcOutput, HaasMapsVariablesDifferentlyAndTakesDiameters) {
  NcMap haas = HaasMap();
  haas.use_variables = true;
  const std::string s = FanucStyleSnippet(haas, BoreResult());
  EXPECT_NE(s.find("#2612 = -0.0062"), std::string::npos) << s;  // diameter wear = 2 x radius
  EXPECT_NE(s.find("#2012 = 101.2046"), std::string::npos) << s;
  EXPECT_EQ(WorkOffsetName(Dialect::kHaas, 7), "G154 P1");
  const std::string syntec = FanucStyleSnippet(SyntecMap(), BoreResult());
  EXPECT_NE(syntec.find("G10 L13 P12 R-0.0062"), std::string::npos) << syntec;
}

TEST(NcOutput, IncrementsWhenTheValueBeforeIsInTheControl) {
  NcResult r;
  r.tools.push_back({12, ToolRegister::kRadiusWear, 0.0, -0.0031, true});
  NcMap fanuc = FanucMap();
  EXPECT_EQ(FanucStyleSnippet(fanuc, r), "G90\nG91 G10 L13 P12 R-0.0031\nG90\n");
  fanuc.use_variables = true;
  EXPECT_EQ(FanucStyleSnippet(fanuc, r), "G90\n#12012 = #12012 - 0.0031\n");
  NcMap haas = HaasMap();
  haas.use_variables = true;
  EXPECT_EQ(FanucStyleSnippet(haas, r), "G90\n#2612 = #2612 - 0.0062\n");
  r.tools[0].reg = ToolRegister::kRadiusGeometry;
  EXPECT_THROW(LinuxCncSubroutine("mlp_result", r), NcOutputError);
}

TEST(NcOutput, ShiftsAWorkOffsetInTheControl) {
  // A bore found 12 um right and 5 um low of where G55 says: G55 X and Y move by that.
  NcResult r;
  WorkOffsetChange w;
  w.index = 2, w.incremental = true, w.axes[2] = false;
  w.after_mm[0] = 0.012, w.after_mm[1] = -0.005;
  r.work.push_back(w);
  EXPECT_EQ(LinuxCncSubroutine("mlp_result", r),
            "o<mlp_result> sub\nG10 L2 P2 X[#5241 + 0.0120] Y[#5242 - 0.0050]\n"
            "o<mlp_result> endsub\nM2\n");
  NcMap fanuc = FanucMap();
  EXPECT_EQ(FanucStyleSnippet(fanuc, r), "G90\nG91 G10 L2 P2 X0.0120 Y-0.0050\nG90\n");
  fanuc.use_variables = true;
  EXPECT_EQ(FanucStyleSnippet(fanuc, r), "G90\n#5241 = #5241 + 0.0120\n#5242 = #5242 - 0.0050\n");
}

TEST(NcOutput, RefusesWhatTheMachineCannotTake) {
  NcMap fanuc = FanucMap();
  fanuc.use_variables = true;
  NcResult r = BoreResult();
  r.tools[0].tool = 201;  // beyond the variables
  EXPECT_THROW(FanucStyleSnippet(fanuc, r), NcOutputError);
  r = BoreResult();
  r.tools[1].after_mm = std::nan("");
  EXPECT_THROW(FanucStyleSnippet(fanuc, r), NcOutputError);
  r = BoreResult();
  r.work[0].rotation_after_deg = 0.5;  // Fanuc keeps no rotation in G54
  EXPECT_THROW(FanucStyleSnippet(fanuc, r), NcOutputError);
  fanuc.rotation_var = 500;
  EXPECT_NE(FanucStyleSnippet(fanuc, r).find("#500 = 0.5000"), std::string::npos);
  r.work[0].index = 6 + 49;
  EXPECT_THROW(FanucStyleSnippet(fanuc, r), NcOutputError);
  NcMap syntec = SyntecMap();
  syntec.use_variables = true;  // no preset variables
  EXPECT_THROW(FanucStyleSnippet(syntec, BoreResult()), NcOutputError);
}

}  // namespace
}  // namespace mlp::nc
