#include "amctl/formats/input.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <filesystem>
#include <cstring>
#include <optional>
#include <vector>

#include <fmt/format.h>
#include <sys/stat.h>
#include <zlib.h>

#include "amctl/core/error.hpp"
#include "amctl/core/input.hpp"
#include "amctl/formats/sources.hpp"

namespace amctl::formats {
namespace {

constexpr std::size_t kPrefixBytes = 512;

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

bool starts_with_word_ci(std::string_view s, std::string_view word) {
  if (s.size() < word.size()) return false;
  for (std::size_t i = 0; i < word.size(); ++i) {
    char c = s[i];
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    if (c != word[i]) return false;
  }
  return s.size() == word.size() || is_space(s[word.size()]);
}

/// "a.gcode.3mf/Metadata/plate_2.gcode" -> the regular file a.gcode.3mf and the member.
bool split_member(const std::string& path, std::string& archive, std::string& member) {
  for (std::size_t slash = path.find('/', 1); slash != std::string::npos;
       slash = path.find('/', slash + 1)) {
    struct stat st{};
    const std::string head = path.substr(0, slash);
    if (::stat(head.c_str(), &st) != 0) return false;
    if (S_ISREG(st.st_mode)) {
      archive = head;
      member = path.substr(slash + 1);
      return !member.empty();
    }
  }
  return false;
}

/// An input opened by the project's one reader (core/input.hpp) before its content is known.
struct RawInput {
  std::unique_ptr<InputFile> file;
  std::string name;       // for messages
  std::string open_path;  // the path that was opened (the archive for a named member)
  std::string member;     // a named member of an archive
  std::string prefix;     // the first bytes (peeked: the file still gives them out)
  bool regular = false;
  std::uint64_t size = 0;
};

void fill_prefix(RawInput& r) {
  r.prefix = std::string(r.file->peek(kPrefixBytes));
  r.regular = r.file->size().has_value();
  r.size = r.file->size().value_or(0);
}

RawInput open_raw(const std::string& path, InputOptions options = gcode::gcode_input_options()) {
  RawInput r;
  r.open_path = path;
  if (path != "-") {
    struct stat st{};
    if (::stat(path.c_str(), &st) != 0 && (errno == ENOTDIR || errno == ENOENT)) {
      std::string archive, member;
      if (split_member(path, archive, member)) {
        r.open_path = archive;
        r.member = member;
      }
    }
  }
  r.file = std::make_unique<InputFile>(r.open_path, std::move(options));
  r.name = r.member.empty() ? r.file->name() : path;
  fill_prefix(r);
  if (!r.member.empty() && !is_zip(r.prefix)) {
    throw Error(SourceLocation{path, 0, 0},
                fmt::format("cannot open G-code file: {} is not a zip archive, so it holds no "
                            "member {}",
                            r.open_path, r.member));
  }
  return r;
}

/// A decoder over an InputFile, owning both.
class OwnedInput final : public gcode::ByteSource {
 public:
  OwnedInput(std::unique_ptr<InputFile> file, std::unique_ptr<gcode::ByteSource> decoded)
      : file_(std::move(file)), decoded_(std::move(decoded)) {}
  std::size_t read(char* dst, std::size_t n) override { return decoded_->read(dst, n); }
  [[nodiscard]] const std::string& name() const override { return file_->name(); }
  [[nodiscard]] std::string origin(std::uint64_t offset) const override { return decoded_->origin(offset); }

 private:
  std::unique_ptr<InputFile> file_;  // declared first: destroyed after the decoder reading it
  std::unique_ptr<gcode::ByteSource> decoded_;
};

/// gzip (or zlib) data inflated as a stream.
class GzipSource final : public gcode::ByteSource {
 public:
  GzipSource(std::unique_ptr<gcode::ByteSource> in, std::string name)
      : in_(std::move(in)), name_(std::move(name)), buf_(64 * 1024) {
    if (inflateInit2(&zs_, 15 + 32) != Z_OK) throw std::bad_alloc();
  }
  ~GzipSource() override { inflateEnd(&zs_); }
  GzipSource(const GzipSource&) = delete;
  GzipSource& operator=(const GzipSource&) = delete;

  std::size_t read(char* dst, std::size_t n) override {
    if (done_) return 0;
    zs_.next_out = reinterpret_cast<Bytef*>(dst);
    zs_.avail_out = static_cast<uInt>(std::min<std::size_t>(n, 1u << 30));
    const uInt want = zs_.avail_out;
    while (zs_.avail_out == want) {
      if (zs_.avail_in == 0) {
        const std::size_t k = in_->read(buf_.data(), buf_.size());
        if (k == 0) {
          if (!at_member_end_) {
            fail("found the end of the file inside the compressed data, expected the rest of "
                 "it (a truncated file?)");
          }
          done_ = true;
          break;
        }
        zs_.next_in = reinterpret_cast<Bytef*>(buf_.data());
        zs_.avail_in = static_cast<uInt>(k);
      }
      if (at_member_end_) {  // another gzip member follows (concatenated files)
        inflateReset(&zs_);
        at_member_end_ = false;
      }
      const int rc = inflate(&zs_, Z_NO_FLUSH);
      if (rc == Z_STREAM_END) {
        at_member_end_ = true;
      } else if (rc != Z_OK && rc != Z_BUF_ERROR) {
        fail(fmt::format("found corrupt gzip data ({}), expected a gzip stream",
                         zs_.msg != nullptr ? zs_.msg : "zlib error"));
      }
    }
    return want - zs_.avail_out;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw Error(SourceLocation{name_, 0, 0}, what);
  }
  std::unique_ptr<gcode::ByteSource> in_;
  std::string name_;
  std::vector<char> buf_;
  z_stream zs_{};
  bool at_member_end_ = false;
  bool done_ = false;
};

[[noreturn]] void model_error(const std::string& name, const char* what) {
  throw Error(SourceLocation{name, 0, 0},
              fmt::format("found a 3D model ({}), expected G-code: this is a model, slice it "
                          "first (for example prusa-slicer --export-gcode {})",
                          what, name));
}

/// A zip read as a stream (standard input, a pipe, a second pass): copied to an unnamed
/// temporary file, since a zip's directory is at its end.
std::FILE* spool(gcode::ByteSource& raw, const std::string& name) {
  std::FILE* t = std::tmpfile();
  if (t == nullptr) {
    throw Error(SourceLocation{name, 0, 0},
                fmt::format("cannot make a temporary copy of the zip archive: {}", std::strerror(errno)));
  }
  std::vector<char> buf(64 * 1024);
  try {
    for (std::size_t k; (k = raw.read(buf.data(), buf.size())) > 0;) {
      if (std::fwrite(buf.data(), 1, k, t) != k) {
        throw Error(SourceLocation{name, 0, 0},
                    fmt::format("cannot make a temporary copy of the zip archive: {}", std::strerror(errno)));
      }
    }
    if (std::fflush(t) != 0) {
      throw Error(SourceLocation{name, 0, 0},
                  fmt::format("cannot make a temporary copy of the zip archive: {}", std::strerror(errno)));
    }
  } catch (...) {
    std::fclose(t);
    throw;
  }
  std::rewind(t);
  return t;
}

ZipArchive open_archive(RawInput& r, const InputLimits& limits) {
  if (r.regular) return ZipArchive(r.open_path, r.name, limits.archive);
  return ZipArchive(spool(*r.file, r.name), r.name, limits.archive);
}

std::string member_list(const std::vector<ArchiveMember>& ms) {
  std::string s;
  for (const auto& m : ms) s += (s.empty() ? "" : ", ") + m.name;
  return s;
}

[[noreturn]] void no_gcode_in_archive(const std::string& name, const ZipArchive& z) {
  if (z.has_model()) model_error(name, "a 3MF project without sliced plates");
  throw Error(SourceLocation{name, 0, 0},
              fmt::format("found a zip archive of {} members and no G-code in it, expected "
                          "G-code text, binary G-code or a sliced 3MF (Metadata/plate_N.gcode)",
                          z.member_count()));
}

/// A non-owning view of a byte source (the decoders below read a stream they do not own).
class BorrowedSource final : public gcode::ByteSource {
 public:
  explicit BorrowedSource(gcode::ByteSource& s) : s_(s) {}
  std::size_t read(char* dst, std::size_t n) override { return s_.read(dst, n); }
  [[nodiscard]] const std::string& name() const override { return s_.name(); }
  [[nodiscard]] std::string origin(std::uint64_t offset) const override { return s_.origin(offset); }

 private:
  gcode::ByteSource& s_;
};

/// The only plate of a sliced 3MF (several are an error naming them).
std::unique_ptr<gcode::ByteSource> one_plate(const ZipArchive& z, const std::string& name) {
  const std::vector<ArchiveMember> ms = z.gcode_members();
  if (ms.empty()) no_gcode_in_archive(name, z);
  if (ms.size() > 1) {
    throw Error(SourceLocation{name, 0, 0},
                fmt::format("found {} plates with G-code ({}), expected one: name it as {}/{}",
                            ms.size(), member_list(ms), name == "<stdin>" ? "FILE" : name, ms[1].name));
  }
  return z.open_member(ms.front().name, true);
}

}  // namespace

bool is_gzip(std::string_view prefix) {
  return prefix.size() >= 2 && static_cast<unsigned char>(prefix[0]) == 0x1f &&
         static_cast<unsigned char>(prefix[1]) == 0x8b;
}

std::unique_ptr<gcode::ByteSource> decode_bgcode(gcode::ByteSource& raw, std::string name,
                                                 const BgcodeLimits& limits) {
  return std::make_unique<BgcodeReader>(std::make_unique<BorrowedSource>(raw), std::move(name), limits);
}

std::unique_ptr<gcode::ByteSource> decode_gzip(gcode::ByteSource& raw, std::string name) {
  return std::make_unique<GzipSource>(std::make_unique<BorrowedSource>(raw), std::move(name));
}

std::unique_ptr<gcode::ByteSource> decode_sliced_3mf(gcode::ByteSource& raw, std::string name,
                                                     const ArchiveLimits& limits) {
  return one_plate(ZipArchive(spool(raw, name), name, limits), name);
}

ContentKind detect_content(std::string_view prefix, std::uint64_t file_size) {
  if (is_bgcode(prefix)) return ContentKind::binary_gcode;
  if (is_zip(prefix)) return ContentKind::zip;
  if (is_gzip(prefix)) return ContentKind::gzip;
  if (file_size >= 84 && prefix.size() >= 84) {
    const auto* p = reinterpret_cast<const unsigned char*>(prefix.data()) + 80;
    const std::uint64_t triangles = static_cast<std::uint64_t>(p[0]) | (static_cast<std::uint64_t>(p[1]) << 8) |
                                    (static_cast<std::uint64_t>(p[2]) << 16) |
                                    (static_cast<std::uint64_t>(p[3]) << 24);
    if (triangles > 0 && file_size == 84 + 50 * triangles) return ContentKind::stl_binary;
  }
  std::string_view t = prefix;
  if (t.starts_with("\xEF\xBB\xBF")) t.remove_prefix(3);  // a UTF-8 byte-order mark
  while (!t.empty() && is_space(t.front())) t.remove_prefix(1);
  if (starts_with_word_ci(t, "solid")) return ContentKind::stl_ascii;
  if (t.starts_with("ISO-10303-21;")) return ContentKind::step;
  return ContentKind::gcode_text;
}

std::unique_ptr<gcode::ByteSource> decode_gcode(InputFile& file, const InputLimits& limits,
                                                GcodeFormat* format) {
  const std::string prefix(file.peek(kPrefixBytes));
  const std::string& name = file.name();
  GcodeFormat f = GcodeFormat::text;
  std::unique_ptr<gcode::ByteSource> out;
  switch (detect_content(prefix, file.size().value_or(0))) {
    case ContentKind::gcode_text:
      if (prefix.starts_with("\xFF\xFE") || prefix.starts_with("\xFE\xFF")) {
        // Notepad's "Unicode": every other byte a NUL, no command would read right.
        throw Error(SourceLocation{name, 1, 1},
                    "found UTF-16 text (byte-order mark FF FE or FE FF), expected ASCII or UTF-8 "
                    "G-code (convert it: iconv -f UTF-16 -t UTF-8)");
      }
      if (prefix.starts_with("\xEF\xBB\xBF")) {
        // A UTF-8 byte-order mark (an editor on Windows): not part of the first line. The
        // columns of line 1 then count as an editor shows them.
        char bom[3];
        std::size_t got = 0;
        while (got < 3) {
          const std::size_t n = file.read(bom + got, 3 - got);
          if (n == 0) break;
          got += n;
        }
      }
      out = std::make_unique<BorrowedSource>(file);
      break;
    case ContentKind::binary_gcode:
      f = GcodeFormat::binary_gcode;
      out = decode_bgcode(file, name, limits.bgcode);
      break;
    case ContentKind::gzip:
      f = GcodeFormat::gzip;
      out = decode_gzip(file, name);
      break;
    case ContentKind::zip:
      f = GcodeFormat::sliced_3mf;
      if (file.size() && file.path() != "-") {
        // A regular file: libzip reads its directory in place, no copy.
        const ZipArchive z(file.path(), name, limits.archive);
        out = one_plate(z, name);
      } else {
        out = decode_sliced_3mf(file, name, limits.archive);
      }
      break;
    case ContentKind::stl_ascii: model_error(name, "an ASCII STL");
    case ContentKind::stl_binary: model_error(name, "a binary STL");
    case ContentKind::step: model_error(name, "a STEP file");
  }
  if (format != nullptr) *format = f;
  return out;
}

GcodeInput open_gcode_input(const std::string& path, const InputLimits& limits) {
  RawInput r = open_raw(path);
  GcodeInput in;
  in.name = r.name;
  const ContentKind kind = detect_content(r.prefix, r.size);
  if (kind != ContentKind::zip) {
    std::unique_ptr<gcode::ByteSource> decoded = decode_gcode(*r.file, limits, &in.format);
    in.bytes = std::make_unique<OwnedInput>(std::move(r.file), std::move(decoded));
    return in;
  }
  in.format = GcodeFormat::sliced_3mf;
  const std::string archive_name = r.member.empty() ? r.name : r.open_path;
  const ZipArchive z = open_archive(r, limits);
  if (!r.member.empty()) {
    in.member = r.member;
    in.bytes = z.open_member(r.member, false);
    return in;
  }
  const std::vector<ArchiveMember> ms = z.gcode_members();
  if (ms.empty()) no_gcode_in_archive(archive_name, z);
  if (ms.size() > 1) {
    throw Error(SourceLocation{archive_name, 0, 0},
                fmt::format("found {} plates with G-code ({}), expected one: name it as {}/{} "
                            "(amctl estimate reads every plate)",
                            ms.size(), member_list(ms), r.name == "<stdin>" ? "FILE" : r.name,
                            ms[1].name));
  }
  in.member = ms.front().name;
  in.bytes = z.open_member(in.member, true);
  return in;
}

std::unique_ptr<gcode::LineReader> open_gcode_reader(InputFile& file, const InputLimits& limits,
                                                     std::size_t buffer_bytes) {
  return std::make_unique<gcode::LineReader>(decode_gcode(file, limits), file.name(), buffer_bytes);
}

std::unique_ptr<gcode::LineReader> open_gcode_reader(const std::string& path, const InputLimits& limits,
                                                     std::size_t buffer_bytes) {
  GcodeInput in = open_gcode_input(path, limits);
  return std::make_unique<gcode::LineReader>(std::move(in.bytes), std::move(in.name), buffer_bytes);
}

std::vector<std::string> gcode_parts(const std::string& path, const InputLimits& limits) {
  if (path == "-") return {path};
  // Only a regular file is looked into here: the first bytes of a pipe, once read, would be
  // gone for the reader that reads it afterwards.
  struct stat st{};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return {path};
  std::optional<RawInput> r;
  try {
    r.emplace(open_raw(path));
  } catch (const Error&) {
    return {path};  // the error comes when the path is opened to be read
  }
  if (!r->member.empty() || detect_content(r->prefix, r->size) != ContentKind::zip || !r->regular) {
    return {path};
  }
  std::vector<ArchiveMember> ms;
  try {
    ms = open_archive(*r, limits).gcode_members();
  } catch (const Error&) {
    return {path};  // a damaged archive: reading it gives the error
  }
  if (ms.size() <= 1) return {path};
  std::vector<std::string> parts;
  for (const auto& m : ms) parts.push_back(path + "/" + m.name);
  return parts;
}

bool has_gcode_suffix(std::string_view name) {
  std::string lower(name);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (const char* suffix : {".gcode", ".gco", ".g", ".bgcode", ".gcode.3mf", ".gcode.gz"}) {
    if (lower.ends_with(suffix)) return true;
  }
  return false;
}

std::vector<std::string> expand_gcode_inputs(const std::vector<std::string>& inputs,
                                             const InputLimits& limits) {
  std::vector<std::string> out;
  for (const std::string& in : inputs) {
    struct stat st{};
    if (in != "-" && ::stat(in.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
      std::vector<std::string> found;
      std::error_code ec;
      for (const auto& e : std::filesystem::directory_iterator(in, ec)) {
        if (e.is_regular_file(ec) && has_gcode_suffix(e.path().filename().string())) {
          found.push_back(e.path().string());
        }
      }
      if (ec) {
        throw Error(SourceLocation{in, 0, 0}, fmt::format("cannot list the directory: {}", ec.message()));
      }
      if (found.empty()) {
        throw Error(SourceLocation{in, 0, 0},
                    "found a directory without G-code, expected files ending in .gcode, .gco, "
                    ".g, .bgcode, .gcode.3mf or .gcode.gz");
      }
      std::sort(found.begin(), found.end());
      for (const std::string& f : found) {
        for (std::string& p : gcode_parts(f, limits)) out.push_back(std::move(p));
      }
      continue;
    }
    for (std::string& p : gcode_parts(in, limits)) out.push_back(std::move(p));
  }
  return out;
}

const char* to_string(GcodeFormat f) {
  switch (f) {
    case GcodeFormat::text: return "text";
    case GcodeFormat::binary_gcode: return "binary G-code";
    case GcodeFormat::sliced_3mf: return "sliced 3MF";
    case GcodeFormat::gzip: return "gzip";
  }
  return "text";
}

}  // namespace amctl::formats
