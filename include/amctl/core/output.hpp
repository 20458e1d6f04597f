#pragma once
// The one output writer of amctl (docs/architecture.md, "Inputs and outputs"). Every file a
// command or the library writes goes through OutputFile:
//  - a regular file (or a path that does not exist yet) is written to a temporary file in the
//    target's directory and renamed over the target by commit(): the target appears whole or
//    not at all. Destroyed without commit() (an exception on the way), the temporary is
//    removed; SIGINT, SIGTERM, SIGHUP and SIGPIPE remove it too (where the process still has
//    the default action for that signal) before the process ends as it would have. A symbolic
//    link is followed: its target is replaced, the link stays.
//  - "-" (standard output), a character device (/dev/null, a terminal), a FIFO (a named pipe,
//    bash's >(...)) is written directly, streamed, never replaced.
//  - a directory, a socket or a missing directory is an error naming the path.
//  - a path that is one of the command's inputs (the same device and inode, so a hard link or
//    a symbolic link to the input counts) is refused before anything is written.
// Every write is checked: a full disk (ENOSPC), a quota, a closed pipe is an amctl::Error
// naming the output, and no partial regular file is left.
#include <cstdint>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace amctl {

/// A file as the system knows it: its device and inode.
struct FileIdentity {
  std::uint64_t device = 0;
  std::uint64_t inode = 0;
  friend bool operator==(const FileIdentity&, const FileIdentity&) = default;
};

/// The identity of the file at `path` (symbolic links followed); nullopt when there is none
/// (or `path` is "-").
[[nodiscard]] std::optional<FileIdentity> identify_file(const std::string& path);

struct OutputOptions {
  /// How the user named this output, for messages: "--csv", "-o/--output" ("" for none).
  std::string flag;
  /// Paths this output must never be (the command's inputs); "-" and "" are skipped.
  std::vector<std::string> inputs;
  /// Identities this output must never be (inputs already open, e.g. InputFile::identity()).
  std::vector<FileIdentity> input_ids;
};

class OutputFile {
 public:
  /// Opens the output (creates the temporary, or opens the device or FIFO). Throws
  /// amctl::Error naming the path when it cannot, or when it is one of options.inputs.
  explicit OutputFile(std::string path, OutputOptions options = {});
  /// check_output(): the checks without opening a device or FIFO.
  OutputFile(std::string path, OutputOptions options, bool only_check);
  /// Without commit(): the temporary file is removed, the target left as it was.
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  /// Appends bytes (buffered). Throws amctl::Error on a write error.
  void write(std::string_view bytes) {
    if (bytes.size() <= capacity_ - used_) {
      std::char_traits<char>::copy(buffer_.get() + used_, bytes.data(), bytes.size());
      used_ += bytes.size();
      return;
    }
    write_slow(bytes);
  }
  void put(char c) { write(std::string_view(&c, 1)); }
  /// A std::ostream over this output (for code that formats with <<). A write error reaches
  /// the caller as the amctl::Error, not as a stream state.
  std::ostream& stream();
  /// Flushes; for a regular file also fsync and rename over the target. Throws amctl::Error.
  void commit();
  /// Replaces bytes already written, at `offset` from the start (a header whose counts are
  /// known only at the end, as in a .npy file). Only for a regular file (not streamed()); the
  /// range must lie within bytes(). Throws amctl::Error on a write error.
  void overwrite_at(std::uint64_t offset, std::string_view replacement);

  /// The path as given.
  [[nodiscard]] const std::string& path() const { return path_; }
  /// True for "-", a device or a FIFO (written directly, not atomically).
  [[nodiscard]] bool streamed() const { return streamed_; }
  [[nodiscard]] bool committed() const { return committed_; }
  /// Bytes written so far.
  [[nodiscard]] std::uint64_t bytes() const { return flushed_ + used_; }

 private:
  void write_slow(std::string_view bytes);
  void flush();
  void write_fd(const char* data, std::size_t n);
  /// Writes all n bytes at the file's position (at < 0; counted in bytes()) or at offset `at`.
  void write_all(const char* data, std::size_t n, long long at);
  [[noreturn]] void fail(const std::string& what, int err);
  void discard() noexcept;

  std::string path_;
  std::string flag_;
  std::string target_;  // the file renamed over (a symbolic link resolved)
  std::string tmp_;     // the temporary ("" when streamed)
  int fd_ = -1;
  int slot_ = -1;       // signal-cleanup registration
  bool streamed_ = false;
  bool stdout_ = false;
  bool committed_ = false;
  bool failed_ = false;
  unsigned mode_ = 0644;
  std::unique_ptr<char[]> buffer_;
  std::size_t capacity_ = 0;
  std::size_t used_ = 0;
  std::uint64_t flushed_ = 0;
  std::unique_ptr<std::ostream> stream_;
  std::unique_ptr<std::streambuf> streambuf_;
};

/// Checks now that `path` can be written as OutputFile would write it (the same errors),
/// without writing it: for a regular file a temporary is created and removed; a device or a
/// FIFO is not opened (opening a FIFO would wait for, then end, its reader).
void check_output(const std::string& path, const OutputOptions& options = {});

/// Writes `content` whole to `path` through an OutputFile (atomically for a regular file).
void write_output(const std::string& path, std::string_view content, const OutputOptions& options = {});

/// Throws amctl::Error when two outputs of one command name the same file ("--csv and
/// --gcode are the same file"), compared by path and, when they exist, by identity.
void require_distinct_outputs(const std::string& a, std::string_view flag_a, const std::string& b,
                              std::string_view flag_b);

}  // namespace amctl
