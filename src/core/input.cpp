// The one input reader (include/amctl/core/input.hpp).
#include "amctl/core/input.hpp"
#include "amctl/core/run_inputs.hpp"
#include "amctl/core/text_input.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <filesystem>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl {
namespace {

// The one piece of process state of the reader: standard input is a resource of the process,
// readable once (a second InputFile of "-" would silently read nothing).
std::atomic<bool> g_stdin_taken{false};

/// A ByteSource that reads another one it does not own.
class Borrowed final : public ByteSource {
 public:
  explicit Borrowed(ByteSource& s) : s_(s) {}
  std::size_t read(char* dst, std::size_t n) override { return s_.read(dst, n); }
  [[nodiscard]] const std::string& name() const override { return s_.name(); }
  [[nodiscard]] std::string origin(std::uint64_t offset) const override { return s_.origin(offset); }

 private:
  ByteSource& s_;
};

/// "a G-code file", "an accelerometer CSV".
std::string a_(const std::string& what) {
  const bool vowel = !what.empty() && std::string_view("aeiouAEIOU").find(what[0]) != std::string_view::npos;
  return (vowel ? "an " : "a ") + what;
}

std::string size_text(std::uint64_t bytes) {
  if (bytes >= (1ull << 30)) return fmt::format("{:.1f} GiB", static_cast<double>(bytes) / (1ull << 30));
  if (bytes >= (1ull << 20)) return fmt::format("{:.1f} MiB", static_cast<double>(bytes) / (1ull << 20));
  return fmt::format("{} bytes", bytes);
}

/// An unlinked temporary file (the copy of a stream for its second pass).
int make_spool() {
  const char* dir = std::getenv("TMPDIR");
  std::string d = dir != nullptr && *dir != '\0' ? dir : "/tmp";
#ifdef O_TMPFILE
  const int fd = ::open(d.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (fd >= 0) return fd;
#endif
  std::string tmpl = d + "/amctl-input-XXXXXX";
  const int f = ::mkostemp(tmpl.data(), O_CLOEXEC);
  if (f >= 0) ::unlink(tmpl.c_str());
  return f;
}

}  // namespace

InputFile::InputFile(const std::string& path, InputOptions options)
    : path_(path), name_(path), options_(std::move(options)) {
  const SourceLocation at{path_, 0, 0};
  if (path_.empty()) throw Error(fmt::format("an empty path, expected {} or '-'", a_(options_.what)));
  if (path_ == "-") {
    // Standard input can be read once: a second reader would find it used up and read
    // nothing (two inputs given as "-", a machine and a G-code file).
    if (g_stdin_taken.exchange(true)) {
      throw Error(fmt::format("'-': standard input is read already by another input of this run; expected "
                              "at most one input from '-'"));
    }
    fd_ = STDIN_FILENO;
    name_ = "<stdin>";
  } else {
    fd_ = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC | O_NOCTTY);
    if (fd_ < 0) {
      const int err = errno;
      if (err == ENOENT) throw Error(at, fmt::format("no such file; expected {}", a_(options_.what)));
      throw Error(at, fmt::format("cannot be opened: {}; expected a readable {}", std::strerror(err), options_.what));
    }
    owns_fd_ = true;
  }
  struct stat st {};
  if (::fstat(fd_, &st) != 0) fail("cannot be examined", errno);
  if (S_ISDIR(st.st_mode)) {
    if (owns_fd_) ::close(fd_);
    fd_ = -1;
    throw Error(SourceLocation{name_, 0, 0}, fmt::format("is a directory; expected {}", a_(options_.what)));
  }
  identity_ = FileIdentity{static_cast<std::uint64_t>(st.st_dev), static_cast<std::uint64_t>(st.st_ino)};
  regular_ = S_ISREG(st.st_mode);
  if (regular_) note_input_of_this_run(*identity_);  // a device or a pipe is not replaced anyway
  if (regular_) {
    // Standard input redirected from a file may start past its beginning.
    const off_t at_open = ::lseek(fd_, 0, SEEK_CUR);
    const auto start = static_cast<std::uint64_t>(at_open > 0 ? at_open : 0);
    size_ = static_cast<std::uint64_t>(st.st_size) - std::min<std::uint64_t>(start, static_cast<std::uint64_t>(st.st_size));
    mtime_ns_ = static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
    if (options_.max_bytes != 0 && *size_ > options_.max_bytes) {
      if (owns_fd_) ::close(fd_);
      fd_ = -1;
      throw Error(SourceLocation{name_, 0, 0},
                  fmt::format("is {}, more than {} may be ({}); expected a smaller file", size_text(*size_),
                              a_(options_.what), size_text(options_.max_bytes)));
    }
    start_offset_ = start;  // where a rewind returns to
  } else if (S_ISFIFO(st.st_mode) && !owns_fd_) {
    identity_.reset();  // an anonymous pipe: nothing a path could name
  }
}

InputFile::~InputFile() {
  if (owns_fd_ && fd_ >= 0) ::close(fd_);
  if (spool_fd_ >= 0) ::close(spool_fd_);
}

void InputFile::fail(const std::string& what, int err) const {
  throw Error(SourceLocation{name_, 0, 0}, fmt::format("{}: {}; expected a readable {}", what, std::strerror(err),
                                                       options_.what));
}

std::size_t InputFile::read_source(char* dst, std::size_t n) {
  ssize_t got = 0;
  for (;;) {
    got = ::read(fd_, dst, n);
    if (got >= 0) break;
    if (errno == EINTR) continue;
    if (errno == EISDIR) {
      throw Error(SourceLocation{name_, 0, 0}, fmt::format("is a directory; expected {}", a_(options_.what)));
    }
    fail("read error", errno);
  }
  const auto g = static_cast<std::size_t>(got);
  if (options_.rewindable && !regular_ && g > 0) {
    if (spool_fd_ < 0) {
      spool_fd_ = make_spool();
      if (spool_fd_ < 0) fail("cannot keep a copy for the second pass", errno);
    }
    std::size_t done = 0;
    while (done < g) {
      const ssize_t w = ::pwrite(spool_fd_, dst + done, g - done, static_cast<off_t>(spool_bytes_ + done));
      if (w < 0) {
        if (errno == EINTR) continue;
        fail("cannot keep a copy for the second pass", errno);
      }
      done += static_cast<std::size_t>(w);
    }
    spool_bytes_ += g;
    if (rewound_) spool_pos_ = spool_bytes_;
  }
  return g;
}

std::size_t InputFile::fetch(char* dst, std::size_t n) {
  std::size_t got = 0;
  if (rewound_ && spool_pos_ < spool_bytes_) {
    const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(n, spool_bytes_ - spool_pos_));
    ssize_t r = 0;
    do {
      r = ::pread(spool_fd_, dst, want, static_cast<off_t>(spool_pos_));
    } while (r < 0 && errno == EINTR);
    if (r <= 0) fail("cannot read the copy kept for the second pass", r < 0 ? errno : EIO);
    got = static_cast<std::size_t>(r);
    spool_pos_ += got;
  } else {
    got = read_source(dst, n);
  }
  return got;
}

std::size_t InputFile::read(char* dst, std::size_t n) {
  AMCTL_CHECK(fd_ >= 0, "InputFile::read on a closed input");
  if (n == 0) return 0;
  std::size_t got = 0;
  if (!peeked_.empty()) {
    got = std::min(n, peeked_.size());
    std::memcpy(dst, peeked_.data(), got);
    peeked_.erase(0, got);
  } else {
    got = fetch(dst, n);
  }
  position_ += got;
  if (options_.max_bytes != 0 && position_ > options_.max_bytes) {
    throw Error(SourceLocation{name_, 0, 0},
                fmt::format("holds more than {} may ({}); expected a smaller input", a_(options_.what),
                            size_text(options_.max_bytes)));
  }
  return got;
}

std::string_view InputFile::peek(std::size_t n) {
  AMCTL_CHECK(position_ == 0, "InputFile::peek after reading");
  while (peeked_.size() < n) {
    char buf[4096];
    const std::size_t got = fetch(buf, std::min(sizeof buf, n - peeked_.size()));
    if (got == 0) break;
    peeked_.append(buf, got);
  }
  return std::string_view(peeked_).substr(0, n);
}

void InputFile::rewind() {
  AMCTL_CHECK(options_.rewindable, "InputFile::rewind without InputOptions::rewindable");
  position_ = 0;
  if (regular_) {
    peeked_.clear();
    struct stat st {};
    if (::fstat(fd_, &st) != 0) fail("cannot be examined", errno);
    const std::int64_t mtime = static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
    if (mtime != mtime_ns_ || static_cast<std::uint64_t>(st.st_size) != *size_ + start_offset_) {
      throw Error(SourceLocation{name_, 0, 0},
                  fmt::format("changed while it was being read; expected {} that stays as it is during "
                              "the run",
                              a_(options_.what)));
    }
    if (::lseek(fd_, static_cast<off_t>(start_offset_), SEEK_SET) < 0) fail("cannot be read again", errno);
    return;
  }
  // A stream: what was read (peeked bytes included) is in the spool; read it from there.
  peeked_.clear();
  rewound_ = true;
  spool_pos_ = 0;
}

namespace {

/// An InputFile and the decoder over it, owned together.
class OwnedDecoded final : public ByteSource {
 public:
  OwnedDecoded(const std::string& path, InputOptions options, const std::vector<Decoder>& decoders)
      : file_(path, std::move(options)), decoded_(decode(file_, decoders)) {}
  std::size_t read(char* dst, std::size_t n) override { return decoded_->read(dst, n); }
  [[nodiscard]] const std::string& name() const override {
    return decoded_->name().empty() ? file_.name() : decoded_->name();
  }
  [[nodiscard]] std::string origin(std::uint64_t offset) const override { return decoded_->origin(offset); }

 private:
  InputFile file_;
  std::unique_ptr<ByteSource> decoded_;
};

}  // namespace

std::unique_ptr<ByteSource> open_decoded(const std::string& path, InputOptions options,
                                         const std::vector<Decoder>& decoders) {
  return std::make_unique<OwnedDecoded>(path, std::move(options), decoders);
}

std::unique_ptr<ByteSource> decode(InputFile& file, const std::vector<Decoder>& decoders) {
  if (!decoders.empty()) {
    const std::string_view first = file.peek(512);
    for (const Decoder& d : decoders) {
      if (d.detect && d.detect(first, file.path())) return d.open(file);
    }
  }
  return std::make_unique<Borrowed>(file);
}

const std::string& ByteSource::name() const {
  static const std::string none;
  return none;
}

// ---------------------------------------------------------------------------------------
// LineReader

LineReader::LineReader(std::unique_ptr<ByteSource> source, std::size_t buffer_bytes)
    : name_(source->name()), owned_(std::move(source)), source_(owned_.get()) {
  buf_.resize(buffer_bytes < 4096 ? 4096 : buffer_bytes);
}

LineReader::LineReader(std::unique_ptr<ByteSource> source, std::string name, std::size_t buffer_bytes)
    : name_(std::move(name)), owned_(std::move(source)), source_(owned_.get()) {
  buf_.resize(buffer_bytes < 4096 ? 4096 : buffer_bytes);
}

LineReader::LineReader(ByteSource& source, std::size_t buffer_bytes) : name_(source.name()), source_(&source) {
  buf_.resize(buffer_bytes < 4096 ? 4096 : buffer_bytes);
}

LineReader::LineReader(std::string_view text, std::string name)
    : name_(std::move(name)), in_memory_(true), memory_(text) {}

LineReader::~LineReader() = default;

bool LineReader::refill() {
  if (eof_) return false;
  if (begin_ > 0) {
    std::memmove(buf_.data(), buf_.data() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  if (end_ == buf_.size()) {
    throw Error(SourceLocation{name_, line_no_ + 1, 0},
                fmt::format("line is longer than {} bytes: expected text lines", buf_.size()));
  }
  const std::size_t got = source_->read(buf_.data() + end_, buf_.size() - end_);
  if (got == 0) {
    eof_ = true;
    return false;
  }
  end_ += got;
  return true;
}

bool LineReader::next_slow(std::string_view& line) {
  for (;;) {
    const char* data = in_memory_ ? memory_.data() : buf_.data() + begin_;
    const std::size_t avail = in_memory_ ? memory_.size() : end_ - begin_;
    const bool at_end = in_memory_ || eof_;
    // No LF in what is there (next() looked): a CR may still end the line.
    const void* cr = avail != 0 ? std::memchr(data, '\r', avail) : nullptr;
    std::size_t len = 0, term = 0;
    if (cr != nullptr) {
      len = static_cast<std::size_t>(static_cast<const char*>(cr) - data);
      if (len + 1 < avail || at_end) {
        term = 1;  // a lone CR (no LF anywhere after it in the buffer)
      } else {
        len = 0;  // a CR as the last byte: an LF may follow in the next read
      }
    }
    if (term == 0 && !at_end) {
      if (refill()) {
        // The inline path finds an LF-ended line; otherwise look again here.
        const char* d2 = buf_.data() + begin_;
        if (std::memchr(d2, '\n', end_ - begin_) != nullptr) return next(line);
        continue;
      }
      continue;  // eof_ now set: the rest is the last line
    }
    if (term == 0) {
      // The end of the input: the rest, if any, is a last line without a terminator.
      if (avail == 0) return false;
      len = avail;
      no_final_newline_ = true;
      terminator_ = "";
    } else {
      terminator_ = "\r";
    }
    line = std::string_view(data, len);
    if (in_memory_) {
      memory_.remove_prefix(len + term);
    } else {
      begin_ += len + term;
    }
    line_start_ = bytes_;
    bytes_ += len + term;
    ++line_no_;
    return true;
  }
}

std::string read_whole_input(const std::string& path, InputOptions options) {
  InputFile in(path, std::move(options));
  std::string out;
  if (in.size()) out.reserve(static_cast<std::size_t>(*in.size()));
  char buf[1 << 16];
  for (std::size_t got = 0; (got = in.read(buf, sizeof buf)) != 0;) out.append(buf, got);
  return out;
}

std::string read_whole_text(const std::string& path, InputOptions options) {
  std::string out = read_whole_input(path, std::move(options));
  // A UTF-8 byte-order mark (an editor on Windows) is not part of the first line (whose
  // columns then count as the editor shows them); UTF-16 is refused, not misread.
  if (out.starts_with("\xEF\xBB\xBF")) {
    out.erase(0, 3);
  } else if (out.starts_with("\xFF\xFE") || out.starts_with("\xFE\xFF")) {
    throw Error(SourceLocation{path == "-" ? std::string("<stdin>") : path, 1, 1},
                "found UTF-16 text (byte-order mark FF FE or FE FF), expected ASCII or UTF-8 "
                "(convert it: iconv -f UTF-16 -t UTF-8)");
  }
  return out;
}

}  // namespace amctl
