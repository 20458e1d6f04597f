// libFuzzer target for amctl's one input reader (core/input.hpp): the byte source, the G-code
// decoders' detection and the line reader. The first input byte picks how the bytes arrive
// (1 to 64 at a time, buffer 4096 or 8192), the rest is the text. Checked against a plain
// reference splitter: the same lines (LF, CRLF, lone CR), the same count of bytes, the same
// "no final line end" flag; the same lines again after a rewind of a rewindable InputFile
// (a scratch file, through the G-code decoders, which drop a leading UTF-8 byte-order mark and
// refuse UTF-16), and from the in-memory reader. Only amctl::Error (an over-long line, a
// binary G-code or 3MF refused) may end a read early, and then on every path alike.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/core/input.hpp"
#include "amctl/gcode/line_reader.hpp"
#include "amctl/formats/input.hpp"
#include "fuzz_support.hpp"

namespace {

using amctl::fuzz::require;

struct Lines {
  std::vector<std::string> lines;
  std::uint64_t bytes = 0;
  bool no_final = false;
  bool error = false;
};

Lines reference(std::string_view t) {
  Lines out;
  std::size_t i = 0;
  while (i < t.size()) {
    std::size_t j = i;
    while (j < t.size() && t[j] != '\n' && t[j] != '\r') ++j;
    out.lines.emplace_back(t.substr(i, j - i));
    if (j == t.size()) {
      out.no_final = true;
      break;
    }
    j += (t[j] == '\r' && j + 1 < t.size() && t[j + 1] == '\n') ? 2 : 1;
    i = j;
  }
  out.bytes = t.size();
  return out;
}

Lines read(amctl::LineReader& r) {
  Lines out;
  try {
    std::string_view line;
    while (r.next(line)) out.lines.emplace_back(line);
    out.bytes = r.bytes_read();
    out.no_final = r.ended_without_newline();
  } catch (const amctl::Error&) {
    out.error = true;
  }
  return out;
}

class Chunks final : public amctl::ByteSource {
 public:
  Chunks(std::string_view t, std::size_t step) : t_(t), step_(step) {}
  std::size_t read(char* dst, std::size_t n) override {
    const std::size_t k = std::min({n, step_, t_.size() - pos_});
    std::copy_n(t_.data() + pos_, k, dst);
    pos_ += k;
    return k;
  }
  [[nodiscard]] const std::string& name() const override { return name_; }

 private:
  std::string_view t_;
  std::size_t step_, pos_ = 0;
  std::string name_ = "fuzz";
};

const amctl::fuzz::ScratchDir& scratch() {
  static const amctl::fuzz::ScratchDir d("line_reader");
  return d;
}

void same(const Lines& a, const Lines& b) {
  require(a.error == b.error);
  if (a.error) return;
  require(a.lines == b.lines);
  require(a.bytes == b.bytes);
  require(a.no_final == b.no_final);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0 || size > 100000) return 0;
  const std::size_t step = 1 + data[0] % 64;
  const std::size_t buffer = data[0] & 0x80 ? 8192 : 4096;
  const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);

  const Lines want = reference(text);
  const bool too_long = std::any_of(want.lines.begin(), want.lines.end(),
                                    [&](const std::string& l) { return l.size() + 2 > buffer; });
  {
    amctl::LineReader r(std::make_unique<Chunks>(text, step), buffer);
    const Lines got = read(r);
    if (!too_long) same(got, want);
    if (!got.error) same(got, want);
  }
  {
    amctl::LineReader r(text, "fuzz");
    same(read(r), want);
  }
  // A file, rewindable, read twice through the G-code decoders.
  const std::string path = (scratch().path() / "in.gcode").string();
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f.write(text.data(), static_cast<std::streamsize>(text.size()));
  }
  const bool plain = amctl::formats::detect_content(text.substr(0, 512), text.size()) ==
                     amctl::formats::ContentKind::gcode_text;
  // The G-code decoders read text without a leading UTF-8 byte-order mark, and refuse UTF-16.
  const bool utf16 = text.starts_with("\xFF\xFE") || text.starts_with("\xFE\xFF");
  const Lines want_decoded = text.starts_with("\xEF\xBB\xBF") ? reference(text.substr(3)) : want;
  try {
    amctl::InputFile file(path, amctl::gcode::gcode_input_options(true));
    Lines first, second;
    {
      const auto rp = amctl::formats::open_gcode_reader(file, {}, buffer);
      amctl::gcode::LineReader& r = *rp;
      first = read(r);
    }
    file.rewind();
    {
      const auto rp = amctl::formats::open_gcode_reader(file, {}, buffer);
      amctl::gcode::LineReader& r = *rp;
      second = read(r);
    }
    same(first, second);
    require(!(plain && utf16));
    if (!first.error && !too_long && plain) same(first, want_decoded);
  } catch (const amctl::Error&) {
    // a container whose decoder refused it (binary G-code, a zip, gzip), a 3D model, UTF-16
    require(!plain || utf16);
  }
  return 0;
}
