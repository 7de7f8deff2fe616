// base/files: whole files in, whole files out; a write that fails leaves the old file and no
// temporary behind.

#include "mlp/base/files.h"

#include <filesystem>
#include <fstream>
#include <ostream>
#include <string>

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
  EXPECT_TRUE(IsTemporaryName(".tool.tbl.mlp-tmp.4242"));
  EXPECT_TRUE(IsTemporaryName(".mlp_result.ngc.mlp-tmp"));  // earlier versions
  EXPECT_TRUE(IsTemporaryName("top.ply.tmp"));              // earlier versions' clouds
  EXPECT_FALSE(IsTemporaryName("tool.tbl"));
  EXPECT_FALSE(IsTemporaryName(".mlp-tmp"));
  EXPECT_FALSE(IsTemporaryName("a.mlp-tmp.1"));  // not hidden: not ours
  EXPECT_FALSE(IsTemporaryName(".a.mlp-tmp.12x"));
  EXPECT_FALSE(IsTemporaryName(".a.mlp-tmp."));
}

}  // namespace
}  // namespace mlp::base
