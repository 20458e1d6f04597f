// The one output writer (include/amctl/core/output.hpp).
#include "amctl/core/output.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/run_inputs.hpp"

namespace amctl {
namespace {

namespace fs = std::filesystem;

// ---- cleanup on a signal ---------------------------------------------------------------
// The one piece of process-wide state in amctl: the temporary files being written, so that a
// signal handler can remove them. A slot is claimed (0 -> 1), filled, published (1 -> 2);
// the handler only reads published slots and calls unlink(), which is async-signal-safe.
constexpr int kSlots = 128;
constexpr std::size_t kSlotPath = 4096;
struct Slot {
  std::atomic<int> state{0};
  char path[kSlotPath];
};
Slot g_slots[kSlots];
std::once_flag g_handlers_once;
constexpr int kCleanupSignals[] = {SIGINT, SIGTERM, SIGHUP, SIGPIPE};

extern "C" void remove_temporaries_on_signal(int sig) {
  for (Slot& s : g_slots) {
    if (s.state.load(std::memory_order_acquire) == 2) ::unlink(s.path);
  }
  // SA_RESETHAND put back the default action; the signal is blocked until we return, then
  // it ends the process as it would have without us.
  ::raise(sig);
}

void install_handlers() {
  for (const int sig : kCleanupSignals) {
    struct sigaction old {};
    if (::sigaction(sig, nullptr, &old) != 0) continue;
    // Only where nobody else decided: a program (Python, a GUI) that handles the signal keeps
    // its handler, and an ignored signal stays ignored.
    if ((old.sa_flags & SA_SIGINFO) != 0 || old.sa_handler != SIG_DFL) continue;
    struct sigaction sa {};
    sa.sa_handler = remove_temporaries_on_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESETHAND;
    ::sigaction(sig, &sa, nullptr);
  }
}

int register_temporary(const std::string& path) {
  std::call_once(g_handlers_once, install_handlers);
  if (path.size() >= kSlotPath) return -1;
  for (int i = 0; i < kSlots; ++i) {
    int expected = 0;
    if (g_slots[i].state.compare_exchange_strong(expected, 1, std::memory_order_acq_rel)) {
      std::memcpy(g_slots[i].path, path.c_str(), path.size() + 1);
      g_slots[i].state.store(2, std::memory_order_release);
      return i;
    }
  }
  return -1;  // more than kSlots outputs open at once: this one is not removed on a signal
}

void unregister_temporary(int slot) {
  if (slot >= 0) g_slots[slot].state.store(0, std::memory_order_release);
}

// ---- helpers -----------------------------------------------------------------------------

/// The process's umask without changing it (umask() would, racing other threads).
mode_t current_umask() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("Umask:", 0) == 0) {
      try {
        return static_cast<mode_t>(std::stoul(line.substr(6), nullptr, 8));
      } catch (...) {
        break;
      }
    }
  }
  return 022;
}

/// Where a symbolic link finally points (the link itself when `path` is not one).
std::string resolve_links(const std::string& path) {
  fs::path p(path);
  for (int hop = 0; hop < 40; ++hop) {
    std::error_code ec;
    if (!fs::is_symlink(fs::symlink_status(p, ec)) || ec) return p.string();
    const fs::path to = fs::read_symlink(p, ec);
    if (ec) return p.string();
    p = to.is_absolute() ? to : p.parent_path() / to;
  }
  return p.string();
}

std::string describe_type(mode_t m) {
  if (S_ISDIR(m)) return "a directory";
  if (S_ISSOCK(m)) return "a socket";
  if (S_ISBLK(m)) return "a block device";
  return "not a regular file";
}

class OutputStreambuf final : public std::streambuf {
 public:
  explicit OutputStreambuf(OutputFile& f) : f_(f) {}

 protected:
  int_type overflow(int_type c) override {
    if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
    f_.put(traits_type::to_char_type(c));
    return c;
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    f_.write(std::string_view(s, static_cast<std::size_t>(n)));
    return n;
  }

 private:
  OutputFile& f_;
};

constexpr std::size_t kBufferBytes = 1u << 18;

}  // namespace

namespace {
std::atomic<bool> g_protect_inputs{false};
std::mutex g_inputs_mutex;
std::vector<FileIdentity>& run_inputs() {
  static std::vector<FileIdentity> ids;
  return ids;
}
}  // namespace

void protect_inputs_of_this_run() { g_protect_inputs = true; }

void note_input_of_this_run(const FileIdentity& id) {
  if (!g_protect_inputs) return;
  const std::lock_guard<std::mutex> lock(g_inputs_mutex);
  std::vector<FileIdentity>& ids = run_inputs();
  if (std::find(ids.begin(), ids.end(), id) == ids.end()) ids.push_back(id);
}

std::vector<FileIdentity> inputs_of_this_run() {
  if (!g_protect_inputs) return {};
  const std::lock_guard<std::mutex> lock(g_inputs_mutex);
  return run_inputs();
}

std::optional<FileIdentity> identify_file(const std::string& path) {
  if (path.empty() || path == "-") return std::nullopt;
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    return FileIdentity{static_cast<std::uint64_t>(st.st_dev), static_cast<std::uint64_t>(st.st_ino)};
  }
  if (errno != ENOTDIR) return std::nullopt;
  // A path inside a regular file: a member of an archive ("a.gcode.3mf/Metadata/plate_2.gcode")
  // is read from that file, so it is that file an output must not be.
  for (std::size_t slash = path.find('/', 1); slash != std::string::npos; slash = path.find('/', slash + 1)) {
    if (::stat(path.substr(0, slash).c_str(), &st) != 0) return std::nullopt;
    if (S_ISREG(st.st_mode)) {
      return FileIdentity{static_cast<std::uint64_t>(st.st_dev), static_cast<std::uint64_t>(st.st_ino)};
    }
  }
  return std::nullopt;
}

OutputFile::OutputFile(std::string path, OutputOptions options)
    : OutputFile(std::move(path), std::move(options), false) {}

OutputFile::OutputFile(std::string path, OutputOptions options, bool only_check)
    : path_(std::move(path)), flag_(std::move(options.flag)) {
  const SourceLocation at{path_, 0, 0};
  const std::string named = flag_.empty() ? std::string() : flag_ + " ";
  if (path_.empty()) {
    throw Error(flag_.empty() ? "output: an empty path, expected a file name or '-'"
                              : fmt::format("{}: an empty path, expected a file name or '-'", flag_));
  }
  std::vector<FileIdentity> inputs = std::move(options.input_ids);
  for (const std::string& in : options.inputs) {
    if (const auto id = identify_file(in)) inputs.push_back(*id);
  }
  for (const FileIdentity& id : inputs_of_this_run()) inputs.push_back(id);
  auto refuse_if_input = [&](const struct stat& st) {
    const FileIdentity id{static_cast<std::uint64_t>(st.st_dev), static_cast<std::uint64_t>(st.st_ino)};
    for (const FileIdentity& in : inputs) {
      if (in == id) {
        throw Error(at, fmt::format("{}is an input of this command; expected a different output "
                                    "file (an input is never overwritten)",
                                    named));
      }
    }
  };

  if (path_ == "-") {
    streamed_ = true;
    stdout_ = true;
    fd_ = STDOUT_FILENO;
    struct stat st {};
    if (::fstat(fd_, &st) == 0 && S_ISREG(st.st_mode)) refuse_if_input(st);
  } else {
    struct stat st {};
    const bool exists = ::stat(path_.c_str(), &st) == 0;
    const int stat_errno = errno;
    if (exists) {
      if (S_ISREG(st.st_mode)) {
        refuse_if_input(st);
        // A file nobody may write (chmod a-w) is one its owner protects: the rename would
        // replace it all the same (it needs only the directory), so it is refused here, as
        // the user's own open() would refuse it (root included, which ignores the bits).
        if ((st.st_mode & 0222) == 0 || ::access(path_.c_str(), W_OK) != 0) {
          throw Error(at, fmt::format("{}is a read-only file (mode {:04o}); expected a writable file or "
                                      "a new name (an output never replaces a protected file)",
                                      named, st.st_mode & 07777));
        }
        mode_ = st.st_mode & 07777;
      } else if (S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode)) {
        refuse_if_input(st);
        streamed_ = true;
      } else {
        throw Error(at, fmt::format("{}is {}; expected a file, a device, a FIFO or '-'", named,
                                    describe_type(st.st_mode)));
      }
    } else if (stat_errno != ENOENT) {
      throw Error(at, fmt::format("{}cannot be written: {}; expected a path in a directory that "
                                  "exists and is writable",
                                  named, std::strerror(stat_errno)));
    } else {
      mode_ = 0666 & ~current_umask();
    }
    if (streamed_ && only_check) {
      return;
    } else if (streamed_) {
      fd_ = ::open(path_.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
      if (fd_ < 0) {
        throw Error(at, fmt::format("{}cannot be opened for writing: {}; expected a writable "
                                    "device or FIFO",
                                    named, std::strerror(errno)));
      }
    } else {
      target_ = resolve_links(path_);
      fs::path dir = fs::path(target_).parent_path();
      if (dir.empty()) dir = ".";
      const std::string tmpl =
          (dir / ("." + fs::path(target_).filename().string() + ".amctl-XXXXXX")).string();
      std::vector<char> buf(tmpl.begin(), tmpl.end());
      buf.push_back('\0');
      fd_ = ::mkostemp(buf.data(), O_CLOEXEC);
      if (fd_ < 0) {
        const int err = errno;
        throw Error(at, fmt::format("{}cannot be written: the directory '{}' {}; expected an "
                                    "existing, writable directory",
                                    named, dir.string(),
                                    err == ENOENT ? std::string("does not exist")
                                                  : fmt::format("refuses it ({})", std::strerror(err))));
      }
      tmp_ = buf.data();
      slot_ = register_temporary(tmp_);
    }
  }
  capacity_ = kBufferBytes;
  buffer_ = std::make_unique<char[]>(capacity_);
}

OutputFile::~OutputFile() {
  if (!committed_) discard();
}

void OutputFile::discard() noexcept {
  if (fd_ >= 0 && !stdout_) ::close(fd_);
  fd_ = -1;
  if (!tmp_.empty()) ::unlink(tmp_.c_str());
  unregister_temporary(slot_);
  slot_ = -1;
}

void OutputFile::fail(const std::string& what, int err) {
  failed_ = true;
  discard();
  std::string reason = std::strerror(err);
  if (err == ENOSPC) reason += " (the disk is full)";
  if (err == EDQUOT) reason += " (the disk quota is used up)";
  if (err == EPIPE) reason = "the reader of the pipe has gone";
  if (err == EFBIG) reason += " (the file size limit)";
  throw Error(SourceLocation{path_, 0, 0},
              fmt::format("{}{} failed: {}; {}", flag_.empty() ? std::string() : flag_ + " ", what,
                          reason,
                          streamed_ ? "expected a reader that takes every byte"
                                    : "expected room for the whole file (nothing was written)"));
}

void OutputFile::write_fd(const char* data, std::size_t n) {
  if (stdout_) std::fflush(stdout);  // what std::cout/printf wrote comes first
  write_all(data, n, -1);
}

void OutputFile::write_all(const char* data, std::size_t n, long long at) {
  while (n > 0) {
    const ssize_t w = at < 0 ? ::write(fd_, data, n) : ::pwrite(fd_, data, n, static_cast<off_t>(at));
    if (w < 0) {
      if (errno == EINTR) continue;
      fail("writing", errno);
    }
    if (w == 0) fail("writing", EIO);
    data += w;
    n -= static_cast<std::size_t>(w);
    if (at < 0) {
      flushed_ += static_cast<std::uint64_t>(w);
    } else {
      at += w;
    }
  }
}

void OutputFile::flush() {
  if (used_ == 0) return;
  const std::size_t n = used_;
  used_ = 0;
  write_fd(buffer_.get(), n);
}

void OutputFile::write_slow(std::string_view bytes) {
  AMCTL_CHECK(fd_ >= 0 && !committed_ && !failed_, "OutputFile::write after commit or failure");
  flush();
  if (bytes.size() >= capacity_) {
    write_fd(bytes.data(), bytes.size());
    return;
  }
  std::char_traits<char>::copy(buffer_.get(), bytes.data(), bytes.size());
  used_ = bytes.size();
}

std::ostream& OutputFile::stream() {
  if (!stream_) {
    streambuf_ = std::make_unique<OutputStreambuf>(*this);
    stream_ = std::make_unique<std::ostream>(streambuf_.get());
    stream_->exceptions(std::ios::badbit);
  }
  return *stream_;
}

void OutputFile::overwrite_at(std::uint64_t offset, std::string_view replacement) {
  AMCTL_CHECK(fd_ >= 0 && !committed_ && !failed_ && !streamed_,
              "OutputFile::overwrite_at on a streamed, committed or failed output");
  AMCTL_CHECK(offset + replacement.size() <= bytes(), "OutputFile::overwrite_at past the end");
  flush();
  write_all(replacement.data(), replacement.size(), static_cast<long long>(offset));
}

void OutputFile::commit() {
  AMCTL_CHECK(fd_ >= 0 && !committed_ && !failed_, "OutputFile::commit twice or after a failure");
  flush();
  if (streamed_) {
    if (!stdout_ && ::close(fd_) != 0 && errno != EINTR) {
      const int err = errno;
      fd_ = -1;
      fail("closing", err);
    }
    fd_ = -1;
    committed_ = true;
    return;
  }
  // An output opened before the work (as the commands do) may name a file the work read
  // afterwards (a machine's [include], an accelerometer record): checked again here, before
  // the rename could replace it.
  if (const auto target = identify_file(target_)) {
    for (const FileIdentity& id : inputs_of_this_run()) {
      if (id == *target) {
        discard();
        failed_ = true;
        throw Error(SourceLocation{path_, 0, 0},
                    fmt::format("{}is an input of this command; expected a different output file (an "
                                "input is never overwritten)",
                                flag_.empty() ? std::string() : flag_ + " "));
      }
    }
  }
  // fsync: the rename must not reach the disk before the data (a crash would leave an empty
  // file where the old one was). EINVAL: a file system without fsync.
  if (::fsync(fd_) != 0 && errno != EINVAL && errno != EROFS) fail("flushing to disk", errno);
  if (::fchmod(fd_, static_cast<mode_t>(mode_)) != 0 && errno != EPERM) fail("setting the permissions", errno);
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0 && errno != EINTR) fail("closing", errno);
  if (std::rename(tmp_.c_str(), target_.c_str()) != 0) fail("renaming the temporary file over it", errno);
  tmp_.clear();
  unregister_temporary(slot_);
  slot_ = -1;
  committed_ = true;
}

void check_output(const std::string& path, const OutputOptions& options) {
  OutputFile probe(path, options, true);  // destroyed uncommitted: its temporary is removed
}

void write_output(const std::string& path, std::string_view content, const OutputOptions& options) {
  OutputFile out(path, options);
  out.write(content);
  out.commit();
}

void require_distinct_outputs(const std::string& a, std::string_view flag_a, const std::string& b,
                              std::string_view flag_b) {
  if (a.empty() || b.empty()) return;
  bool same = a == b;
  if (!same) {
    const auto ia = identify_file(a);
    const auto ib = identify_file(b);
    same = ia && ib && *ia == *ib;
  }
  if (same) {
    throw Error(fmt::format("{}: '{}' is also the {} file, expected two different outputs", flag_b,
                            b, flag_a));
  }
}

}  // namespace amctl
