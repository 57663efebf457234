// The one atomic writer (include/ftid/fileio/atomic_file.hpp): replaces only regular files,
// never follows a symlink, leaves nothing behind on refusal, keeps modes and the .bak copy.
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "ftid/fileio/atomic_file.hpp"
#include "scratch.hpp"

namespace ftid {
namespace {

using test::ScratchDir;
using test::slurp;
using test::spit;

bool isSymlink(const std::string& p) {
  struct stat st {};
  return ::lstat(p.c_str(), &st) == 0 && S_ISLNK(st.st_mode);
}

TEST(AtomicFile, CreatesAndReplacesRegularFiles) {
  ScratchDir d("fileio");
  writeFileAtomically(d / "a.txt", "first\n");
  EXPECT_EQ(slurp(d / "a.txt"), "first\n");
  ASSERT_EQ(::chmod((d / "a.txt").c_str(), 0640), 0);
  writeFileAtomically(d / "a.txt", "second\n");
  EXPECT_EQ(slurp(d / "a.txt"), "second\n");
  struct stat st {};
  ASSERT_EQ(::stat((d / "a.txt").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0640u) << "an existing file keeps its mode";
  EXPECT_EQ(d.entries(), std::vector<std::string>{"a.txt"}) << "no temporary file left";
}

TEST(AtomicFile, RefusesToReplaceASymlinkAndLeavesBothUntouched) {
  ScratchDir d("fileio");
  spit(d / "target.txt", "precious\n");
  ASSERT_EQ(::symlink("target.txt", (d / "link.txt").c_str()), 0);
  try {
    writeFileAtomically(d / "link.txt", "attack\n");
    FAIL() << "wrote through or over a symlink";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find(d / "link.txt"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("symbolic link"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(isSymlink(d / "link.txt"));
  EXPECT_EQ(slurp(d / "target.txt"), "precious\n");
  EXPECT_EQ(d.entries(), (std::vector<std::string>{"link.txt", "target.txt"}));
  // A dangling symlink is refused too (it must not create the file it points to).
  ASSERT_EQ(::symlink("nowhere.txt", (d / "dangling").c_str()), 0);
  EXPECT_THROW(writeFileAtomically(d / "dangling", "x"), FileError);
  EXPECT_FALSE(std::filesystem::exists(d / "nowhere.txt"));
}

TEST(AtomicFile, RefusesFifoDirectoryAndDeviceNode) {
  ScratchDir d("fileio");
  ASSERT_EQ(::mkfifo((d / "fifo").c_str(), 0600), 0);
  ASSERT_EQ(::mkdir((d / "dir").c_str(), 0700), 0);
  for (const auto& [name, kind] : {std::pair<std::string, std::string>{"fifo", "FIFO"}, {"dir", "directory"}}) {
    try {
      writeFileAtomically(d / name, "x");
      FAIL() << name;
    } catch (const FileError& e) {
      EXPECT_NE(std::string(e.what()).find(d / name), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(kind), std::string::npos) << e.what();
    }
  }
  struct stat st {};
  ASSERT_EQ(::lstat((d / "fifo").c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  // A character device: a private node as root (CI), /dev/null otherwise (unprivileged users
  // cannot create one, and the check refuses before any permission problem could).
  std::string dev = "/dev/null";
  if (::geteuid() == 0 && ::mknod((d / "null").c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0) dev = d / "null";
  try {
    writeFileAtomically(dev, "x");
    FAIL() << dev;
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("character device"), std::string::npos) << e.what();
  }
  ASSERT_EQ(::lstat(dev.c_str(), &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode)) << dev << " was replaced";
  EXPECT_THROW(checkOutputPath(dev), FileError);
  EXPECT_THROW(checkOutputPath(d / "fifo"), FileError);
  EXPECT_NO_THROW(checkOutputPath(d / "new.txt"));
}

TEST(AtomicFile, KeepsTheReplacedFileAsBackupOnlyWhenAsked) {
  ScratchDir d("fileio");
  AtomicWriteOptions keep;
  keep.keep_backup = true;
  writeFileAtomically(d / "p.yaml", "v1\n", keep);
  EXPECT_FALSE(std::filesystem::exists(d / "p.yaml.bak")) << "nothing to back up yet";
  writeFileAtomically(d / "p.yaml", "v2\n", keep);
  EXPECT_EQ(slurp(d / "p.yaml"), "v2\n");
  EXPECT_EQ(slurp(d / "p.yaml.bak"), "v1\n");
  writeFileAtomically(d / "p.yaml", "v3\n");
  EXPECT_EQ(slurp(d / "p.yaml.bak"), "v1\n") << "no rotation without keep_backup";
  // A symlinked backup name is refused before anything changes.
  std::filesystem::remove(d / "p.yaml.bak");
  spit(d / "elsewhere", "keep me\n");
  ASSERT_EQ(::symlink("elsewhere", (d / "p.yaml.bak").c_str()), 0);
  EXPECT_THROW(writeFileAtomically(d / "p.yaml", "v4\n", keep), FileError);
  EXPECT_EQ(slurp(d / "p.yaml"), "v3\n");
  EXPECT_EQ(slurp(d / "elsewhere"), "keep me\n");
  EXPECT_TRUE(isSymlink(d / "p.yaml.bak"));
}

TEST(AtomicFile, MissingDirectoryIsNamed) {
  ScratchDir d("fileio");
  try {
    writeFileAtomically(d / "no/such/dir/out.csv", "x");
    FAIL();
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find(d / "no/such/dir"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ftid
