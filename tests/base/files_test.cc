// base/files: whole files in, whole files out; a write that fails leaves the old file and no
// temporary behind.

#include "mlp/base/files.h"

#include "mlp/base/clock.h"
#include "mlp/base/csv.h"

#include <filesystem>
#include <fstream>
#include <mutex>
#include <ostream>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

namespace mlp::base {
namespace {

namespace fs = std::filesystem;

class FilesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("mlp_base_files_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  int Entries() const {
    int n = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++n;
    return n;
  }
  fs::path dir_;
};

TEST_F(FilesTest, WritesThenReadsTheSameBytes) {
  const std::string bytes("a\0b\nc\xff", 6);  // binary: a NUL and a high byte survive
  WriteFileAtomically(Path("x.bin"), bytes);
  EXPECT_EQ(ReadFile(Path("x.bin")), bytes);
  EXPECT_EQ(Entries(), 1);  // no temporary left
}

TEST_F(FilesTest, ReplacingKeepsThePermissionBits) {
  WriteFileAtomically(Path("tool.tbl"), "T1 P1\n");
  ::chmod(Path("tool.tbl").c_str(), 0640);
  WriteFileAtomically(Path("tool.tbl"), "T1 P1 Z2\n");
  struct stat st {};
  ASSERT_EQ(::stat(Path("tool.tbl").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0640u);
  EXPECT_EQ(ReadFile(Path("tool.tbl")), "T1 P1 Z2\n");
}

TEST_F(FilesTest, NeverReplaceRefusesAnExistingFileAndKeepsIt) {
  WriteFileAtomically(Path("rec.json"), "first", Replace::kNever);
  EXPECT_THROW(WriteFileAtomically(Path("rec.json"), "second", Replace::kNever), FileError);
  EXPECT_EQ(ReadFile(Path("rec.json")), "first");
  EXPECT_EQ(Entries(), 1);
}

TEST_F(FilesTest, AStreamWriterThatThrowsLeavesTheOldFileAndNoTemporary) {
  WriteFileAtomically(Path("cloud.ply"), "old");
  EXPECT_THROW(WriteFileAtomically(Path("cloud.ply"),
                                   [](std::ostream& out) {
                                     out << "half a cloud";
                                     throw FileError("cut short");
                                   }),
               FileError);
  EXPECT_EQ(ReadFile(Path("cloud.ply")), "old");
  EXPECT_EQ(Entries(), 1);  // the temporary is gone too
}

TEST_F(FilesTest, AFolderThatIsAFileIsATypedErrorNamingThePath) {
  WriteFileAtomically(Path("plain"), "a file, not a folder");  // refused even for root
  try {
    WriteFileAtomically(Path("plain/x"), "y");
    FAIL() << "no error";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find(Path("plain")), std::string::npos) << e.what();
  }
  EXPECT_EQ(ReadFile(Path("plain")), "a file, not a folder");
}

TEST_F(FilesTest, AMissingFolderAndAMissingFileAreTypedErrors) {
  EXPECT_THROW(WriteFileAtomically(Path("no/such/x"), "y"), FileError);
  try {
    ReadFile(Path("absent.json"));
    FAIL() << "no error";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("absent.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("No such file"), std::string::npos) << e.what();
  }
}

struct ModuleError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

TEST_F(FilesTest, ReadFileAsRaisesTheModulesErrorWithItsPrefix) {
  try {
    ReadFileAs<ModuleError>(Path("absent"), "scene: ");
    FAIL() << "no error";
  } catch (const ModuleError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("scene: cannot read ", 0), 0u) << e.what();
  }
}

TEST(TemporaryNames, AreRecognisedAndRealFilesAreNot) {
  EXPECT_TRUE(IsTemporaryName(".tool.tbl.mlp-tmp.4242.17"));  // process 4242's 18th write
  EXPECT_TRUE(IsTemporaryName(".tool.tbl.mlp-tmp.4242"));     // earlier versions
  EXPECT_TRUE(IsTemporaryName(".mlp_result.ngc.mlp-tmp"));    // earlier versions
  EXPECT_TRUE(IsTemporaryName("top.ply.tmp"));                // earlier versions' clouds
  EXPECT_FALSE(IsTemporaryName("tool.tbl"));
  EXPECT_FALSE(IsTemporaryName(".mlp-tmp"));
  EXPECT_FALSE(IsTemporaryName("a.mlp-tmp.1"));  // not hidden: not ours
  EXPECT_FALSE(IsTemporaryName(".a.mlp-tmp.12x"));
  EXPECT_FALSE(IsTemporaryName(".a.mlp-tmp."));
  EXPECT_FALSE(IsTemporaryName(".a.mlp-tmp.12."));
  EXPECT_FALSE(IsTemporaryName(".a.mlp-tmp.12.3.4"));
}

// Threads of one process take turns on a FileLock as processes do (flock on each holder's own
// descriptor); a holder that never lets go makes the waiter fail, named, not hang.
TEST_F(FilesTest, AFileLockMakesThreadsTakeTurnsAndAWaiterGivesUp) {
  const std::string lock = Path(".table.mlp-lock");
  int inside = 0, most_inside = 0;
  std::mutex count_m;
  const auto worker = [&] {
    for (int k = 0; k < 50; ++k) {
      FileLock held(lock);
      {
        std::lock_guard g(count_m);
        most_inside = std::max(most_inside, ++inside);
      }
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      std::lock_guard g(count_m);
      --inside;
    }
  };
  std::thread a(worker), b(worker);
  a.join(), b.join();
  EXPECT_EQ(most_inside, 1);
  FileLock held(lock);
  try {
    FileLock other(lock, /*wait_ms=*/50);
    FAIL() << "a second holder";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("held by another writer"), std::string::npos) << e.what();
  }
}

TEST(Csv, FieldsAreQuotedOnlyWhenTheyMustBe) {  // RFC 4180 section 2
  EXPECT_EQ(CsvField("T13-EM10"), "T13-EM10");
  EXPECT_EQ(CsvField("DR6, spare"), "\"DR6, spare\"");
  EXPECT_EQ(CsvField("6\" drill"), "\"6\"\" drill\"");
  EXPECT_EQ(CsvField("two\nlines"), "\"two\nlines\"");
  EXPECT_EQ(CsvField(""), "");
}

TEST(Clock, UtcTimestampIsIso8601WithMilliseconds) {
  const std::string t = UtcTimestamp();  // e.g. 2026-11-21T23:57:01.123Z
  ASSERT_EQ(t.size(), 24u) << t;
  EXPECT_EQ(t[4], '-');
  EXPECT_EQ(t[10], 'T');
  EXPECT_EQ(t[19], '.');
  EXPECT_EQ(t.back(), 'Z');
  EXPECT_EQ(UtcNow("%Y%m%dT%H%M%SZ", false).size(), 16u);
}

TEST_F(FilesTest, AppendRecordWritesTheHeaderOnceAndWholeLines) {
  const std::string log = Path("changes.csv");
  AppendRecord(log, "a,b\n", "1,2\n");
  AppendRecord(log, "a,b\n", "3,4\n");
  EXPECT_EQ(ReadFile(log), "a,b\n1,2\n3,4\n");
  // Two writers at once: every line arrives whole (one write() per record on O_APPEND).
  constexpr int kLinesPerWriter = 300;
  const std::string long_a(200, 'a'), long_b(200, 'b');
  const auto writer = [&](const std::string& text) {
    for (int i = 0; i < kLinesPerWriter; ++i) AppendRecord(log, "a,b\n", text + "\n");
  };
  std::thread first(writer, long_a), second(writer, long_b);
  first.join();
  second.join();
  std::istringstream lines(ReadFile(log));
  std::string line;
  int a = 0, b = 0, other = 0;
  while (std::getline(lines, line)) (line == long_a ? a : line == long_b ? b : other)++;
  EXPECT_EQ(a, kLinesPerWriter);
  EXPECT_EQ(b, kLinesPerWriter);
  EXPECT_EQ(other, 3);  // the header and the two short records
  EXPECT_THROW(AppendRecord(Path("no/such/folder.csv"), "h\n", "x\n"), FileError);
}

}  // namespace
}  // namespace mlp::base
