#include "amctl/gcode/line_reader.hpp"

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::gcode {

LineReader::LineReader(const std::string& path, std::size_t buffer_bytes) : name_(path) {
  if (path == "-") {
    file_ = stdin;
    name_ = "<stdin>";
  } else {
    file_ = std::fopen(path.c_str(), "rb");
    if (file_ == nullptr) {
      throw Error(SourceLocation{path, 0, 0},
                  fmt::format("cannot open G-code file: {}", std::strerror(errno)));
    }
    owns_file_ = true;
  }
  buf_.resize(buffer_bytes < 4096 ? 4096 : buffer_bytes);
}

LineReader::LineReader(std::string_view text, std::string name)
    : name_(std::move(name)), in_memory_(true), memory_(text) {}

LineReader::LineReader(std::unique_ptr<ByteSource> source, std::string name,
                       std::size_t buffer_bytes)
    : name_(std::move(name)), source_(std::move(source)) {
  AMCTL_CHECK(source_ != nullptr, "LineReader needs a byte source");
  buf_.resize(buffer_bytes < 4096 ? 4096 : buffer_bytes);
}

LineReader::~LineReader() {
  if (owns_file_ && file_ != nullptr) std::fclose(file_);
}

bool LineReader::refill() {
  if (eof_) return false;
  if (begin_ > 0) {
    std::memmove(buf_.data(), buf_.data() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  if (end_ == buf_.size()) {
    throw Error(SourceLocation{name_, line_no_ + 1, 0},
                fmt::format("line is longer than {} bytes: expected G-code text lines",
                            buf_.size()));
  }
  if (source_) {
    const std::size_t got = source_->read(buf_.data() + end_, buf_.size() - end_);
    if (got == 0) {
      eof_ = true;
      return false;
    }
    end_ += got;
    return true;
  }
  std::size_t got = std::fread(buf_.data() + end_, 1, buf_.size() - end_, file_);
  if (got == 0) {
    if (std::ferror(file_)) {
      throw Error(SourceLocation{name_, line_no_ + 1, 0},
                  fmt::format("read error: {}", std::strerror(errno)));
    }
    eof_ = true;
    return false;
  }
  end_ += got;
  return true;
}

bool LineReader::next_slow(std::string_view& line) {
  if (in_memory_) {
    if (memory_.empty()) return false;
    std::size_t nl = memory_.find('\n');
    std::string_view l = memory_.substr(0, nl);
    if (nl == std::string_view::npos) {
      memory_ = {};
      no_final_newline_ = true;
    } else {
      memory_.remove_prefix(nl + 1);
    }
    line_start_ = bytes_;
    bytes_ += l.size() + 1;
    if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
    ++line_no_;
    line = l;
    return true;
  }
  for (;;) {
    const char* data = buf_.data();
    const void* hit = std::memchr(data + begin_, '\n', end_ - begin_);
    if (hit != nullptr) {
      std::size_t nl = static_cast<std::size_t>(static_cast<const char*>(hit) - data);
      std::string_view l(data + begin_, nl - begin_);
      line_start_ = bytes_;
      bytes_ += nl + 1 - begin_;
      begin_ = nl + 1;
      if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
      ++line_no_;
      line = l;
      return true;
    }
    if (!refill()) {
      if (begin_ == end_) return false;
      std::string_view l(buf_.data() + begin_, end_ - begin_);
      line_start_ = bytes_;
      bytes_ += end_ - begin_;
      begin_ = end_;
      no_final_newline_ = true;
      if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
      ++line_no_;
      line = l;
      return true;
    }
  }
}

}  // namespace amctl::gcode
