// The one output writer (core/output.hpp): what a regular file, a device, a FIFO, a full disk,
// an input and a signal each do to an output.
#include "amctl/core/output.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/core/input.hpp"
#include "amctl/core/run_inputs.hpp"

namespace amctl {
namespace {

namespace fs = std::filesystem;

class OutputTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("amctl_output_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  static std::string slurp(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }
  static void spit(const std::string& p, const std::string& text) {
    std::ofstream(p, std::ios::binary) << text;
  }
  /// Every entry of the directory (the temporaries are hidden files).
  std::size_t entries() const {
    return static_cast<std::size_t>(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()));
  }
  fs::path dir_;
};

TEST_F(OutputTest, ARegularFileAppearsWholeAtCommit) {
  const std::string p = path("out.csv");
  {
    OutputFile out(p);
    EXPECT_FALSE(out.streamed());
    out.write("a,b\n");
    for (int i = 0; i < 100000; ++i) out.write("1,2\n");  // beyond the buffer
    EXPECT_FALSE(fs::exists(p));  // nothing at the target before commit
    out.commit();
    EXPECT_EQ(out.bytes(), 4u + 400000u);
  }
  EXPECT_EQ(fs::file_size(p), 400004u);
  EXPECT_EQ(entries(), 1u);  // no temporary left
}

TEST_F(OutputTest, WithoutCommitTheOldFileStaysAndNoTemporaryIsLeft) {
  const std::string p = path("out.csv");
  spit(p, "old content\n");
  {
    OutputFile out(p);
    out.write("new, half written");
  }
  EXPECT_EQ(slurp(p), "old content\n");
  EXPECT_EQ(entries(), 1u);
}

TEST_F(OutputTest, AnExistingFileKeepsItsPermissions) {
  const std::string p = path("out.txt");
  spit(p, "x");
  ASSERT_EQ(::chmod(p.c_str(), 0640), 0);
  write_output(p, "y");
  struct stat st {};
  ASSERT_EQ(::stat(p.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0640u);
  EXPECT_EQ(slurp(p), "y");
}

TEST_F(OutputTest, ASymbolicLinkIsFollowedAndKept) {
  const std::string target = path("real.txt"), link = path("link.txt");
  spit(target, "old");
  fs::create_symlink("real.txt", link);
  write_output(link, "new");
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(slurp(target), "new");
}

TEST_F(OutputTest, TheInputIsNeverOverwritten) {
  const std::string in = path("in.gcode");
  spit(in, "G1 X1\n");
  fs::create_hard_link(in, path("hard.gcode"));
  fs::create_symlink("in.gcode", path("soft.gcode"));
  for (const char* name : {"in.gcode", "hard.gcode", "soft.gcode"}) {
    try {
      OutputFile out(path(name), OutputOptions{"-o", {in}, {}});
      ADD_FAILURE() << name << " was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("input"), std::string::npos) << e.what();
    }
  }
  // By identity too (an input already open).
  const auto id = identify_file(in);
  ASSERT_TRUE(id);
  EXPECT_THROW(OutputFile(path("hard.gcode"), OutputOptions{"-o", {}, {*id}}), Error);
  EXPECT_EQ(slurp(in), "G1 X1\n");
  EXPECT_NO_THROW(write_output(path("other.csv"), "ok", OutputOptions{"-o", {in}, {}}));
}

TEST_F(OutputTest, ADirectoryOrAMissingDirectoryIsAnErrorNamingThePath) {
  try {
    OutputFile out(dir_.string(), OutputOptions{"--csv", {}, {}});
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.where().file, dir_.string());
    EXPECT_NE(std::string(e.what()).find("directory"), std::string::npos);
  }
  try {
    OutputFile out(path("no/such/dir/out.csv"));
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  EXPECT_THROW(OutputFile(""), Error);
}

TEST_F(OutputTest, AFifoIsStreamedNotReplaced) {
  const std::string p = path("pipe");
  ASSERT_EQ(::mkfifo(p.c_str(), 0600), 0);
  std::string got;
  std::thread reader([&] {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    got = ss.str();
  });
  {
    OutputFile out(p);
    EXPECT_TRUE(out.streamed());
    for (int i = 0; i < 50000; ++i) out.write("0123456789\n");
    out.commit();
  }
  reader.join();
  EXPECT_EQ(got.size(), 550000u);
  struct stat st {};
  ASSERT_EQ(::lstat(p.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  // check_output does not open a FIFO (it would wait for a reader).
  EXPECT_NO_THROW(check_output(p));
}

TEST_F(OutputTest, ACharacterDeviceIsStreamedAndAFullOneIsAnError) {
  if (::geteuid() != 0) GTEST_SKIP() << "making device nodes needs root";
  const std::string null_dev = path("null"), full_dev = path("full");
  ASSERT_EQ(::mknod(null_dev.c_str(), S_IFCHR | 0666, makedev(1, 3)), 0);
  ASSERT_EQ(::mknod(full_dev.c_str(), S_IFCHR | 0666, makedev(1, 7)), 0);
  write_output(null_dev, std::string(1 << 20, 'x'));
  struct stat st {};
  ASSERT_EQ(::lstat(null_dev.c_str(), &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  try {
    write_output(full_dev, std::string(1 << 20, 'x'), OutputOptions{"--csv", {}, {}});
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("No space left"), std::string::npos) << e.what();
  }
  ASSERT_EQ(::lstat(full_dev.c_str(), &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
}

// A write that fails half way (here the file size limit, EFBIG, standing for a full disk)
// is an error and leaves neither the target nor a temporary. In a child: the limit is the
// process's.
TEST_F(OutputTest, AFailedWriteLeavesNothing) {
  const std::string p = path("big.csv");
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::signal(SIGXFSZ, SIG_IGN);
    struct rlimit rl {1 << 16, 1 << 16};
    ::setrlimit(RLIMIT_FSIZE, &rl);
    try {
      OutputFile out(p);
      for (int i = 0; i < 100000; ++i) out.write("0123456789\n");
      out.commit();
    } catch (const Error& e) {
      ::_exit(std::string(e.what()).find("File too large") != std::string::npos ? 7 : 8);
    }
    ::_exit(9);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 7);
  EXPECT_EQ(entries(), 0u);
}

// SIGTERM during a write removes the temporary, and the process still ends by SIGTERM.
TEST_F(OutputTest, ASignalRemovesTheTemporary) {
  const std::string p = path("out.csv");
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    OutputFile out(p);
    out.write(std::string(1 << 20, 'x'));
    ::raise(SIGTERM);
    ::_exit(0);  // not reached
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFSIGNALED(status));
  EXPECT_EQ(WTERMSIG(status), SIGTERM);
  EXPECT_EQ(entries(), 0u);
}

TEST_F(OutputTest, TheStreamFormsAndReportsErrorsAsErrors) {
  const std::string p = path("s.txt");
  {
    OutputFile out(p);
    out.stream() << "x=" << 1.5 << ' ' << 42 << '\n';
    out.commit();
  }
  EXPECT_EQ(slurp(p), "x=1.5 42\n");
}

TEST_F(OutputTest, TwoOutputsOfOneCommandMustDiffer) {
  const std::string a = path("a.csv");
  spit(a, "1");
  fs::create_hard_link(a, path("b.csv"));
  EXPECT_THROW(require_distinct_outputs(a, "--csv", a, "--gcode"), Error);
  EXPECT_THROW(require_distinct_outputs(a, "--csv", path("b.csv"), "--gcode"), Error);
  EXPECT_THROW(require_distinct_outputs("-", "--csv", "-", "--gcode"), Error);
  EXPECT_NO_THROW(require_distinct_outputs(a, "--csv", path("c.csv"), "--gcode"));
  EXPECT_NO_THROW(require_distinct_outputs(a, "--csv", "", "--gcode"));
}

TEST_F(OutputTest, AReadOnlyFileIsRefusedNotReplaced) {
  // The rename would replace it (it needs only the directory), and root ignores the bits:
  // a file nobody may write is its owner's protection, kept.
  const std::string p = path("ro.csv");
  spit(p, "keep");
  ASSERT_EQ(::chmod(p.c_str(), 0444), 0);
  try {
    write_output(p, "new", OutputOptions{"--csv", {}, {}});
    FAIL() << "a read-only file was replaced";
  } catch (const Error& e) {
    EXPECT_EQ(e.where().file, p);
    EXPECT_NE(std::string(e.what()).find("--csv is a read-only file (mode 0444); expected"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(slurp(p), "keep");
  EXPECT_EQ(entries(), 1u);
}

TEST_F(OutputTest, APlateOfAnArchiveIsIdentifiedAsTheArchive) {
  const std::string archive = path("p.gcode.3mf");
  spit(archive, "PK");
  const auto whole = identify_file(archive);
  ASSERT_TRUE(whole.has_value());
  EXPECT_EQ(identify_file(archive + "/Metadata/plate_2.gcode"), whole);
  EXPECT_FALSE(identify_file(path("none.gcode.3mf") + "/Metadata/plate_1.gcode").has_value());
  // So an output through a link to the archive is refused as the input.
  ASSERT_EQ(::symlink(archive.c_str(), path("l.gcode").c_str()), 0);
  EXPECT_THROW(write_output(path("l.gcode"), "x", OutputOptions{"--write-m73", {archive + "/Metadata/plate_2.gcode"}, {}}),
               Error);
  EXPECT_EQ(slurp(archive), "PK");
}

TEST_F(OutputTest, WithTheRunsInputsProtectedNoFileItReadCanBeAnOutput) {
  // The executable's mode (core/run_inputs.hpp), process-wide: tried in a child process so
  // the other tests of this binary keep the library's default (off).
  const std::string cfg = path("p.cfg");
  const std::string other = path("o.csv");
  spit(cfg, "[printer]\n");
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    int code = 0;
    try {
      (void)read_whole_input(cfg);  // before protection: not noted
      write_output(other, "1");
      protect_inputs_of_this_run();
      (void)read_whole_input(cfg);
      try {
        write_output(cfg, "replaced", OutputOptions{"--csv", {}, {}});
        code = 10;
      } catch (const Error& e) {
        if (std::string(e.what()).find("is an input of this command") == std::string::npos) code = 11;
      }
      write_output(other, "2");  // any other file is written as before
    } catch (...) {
      code = 12;
    }
    ::_exit(code);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  EXPECT_EQ(slurp(cfg), "[printer]\n");
  EXPECT_EQ(slurp(other), "2");
  EXPECT_TRUE(inputs_of_this_run().empty());  // this process: off
}

}  // namespace
}  // namespace amctl
