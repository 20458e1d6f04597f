#include "amctl/formats/sliced_3mf.hpp"

#include <algorithm>
#include <charconv>
#include <string_view>

#include <fmt/format.h>
#include <zip.h>

#include "amctl/core/error.hpp"

namespace amctl::formats {
namespace {

/// N of "Metadata/plate_N.gcode", else 0.
int plate_number(std::string_view name) {
  constexpr std::string_view head = "Metadata/plate_", tail = ".gcode";
  if (!name.starts_with(head) || !name.ends_with(tail)) return 0;
  const std::string_view digits = name.substr(head.size(), name.size() - head.size() - tail.size());
  int n = 0;
  const auto [p, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), n);
  if (ec != std::errc() || p != digits.data() + digits.size() || n <= 0) return 0;
  return n;
}

std::string zip_message(int code) {
  zip_error_t e;
  zip_error_init_with_code(&e, code);
  std::string m = zip_error_strerror(&e);
  zip_error_fini(&e);
  return m;
}

}  // namespace

struct ZipArchive::Impl {
  zip_t* zip = nullptr;
  std::string name;
  ArchiveLimits limits;
  std::vector<ArchiveMember> members;
  ~Impl() {
    if (zip != nullptr) zip_discard(zip);
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw Error(SourceLocation{name, 0, 0}, what);
  }
  void list();
};

void ZipArchive::Impl::list() {
  const zip_int64_t n = zip_get_num_entries(zip, 0);
  if (n < 0) fail("found a zip archive whose directory cannot be read, expected a 3MF archive");
  if (static_cast<std::uint64_t>(n) > limits.max_members) {
    fail(fmt::format("found a zip archive of {} members, expected at most {}", n,
                     limits.max_members));
  }
  for (zip_int64_t i = 0; i < n; ++i) {
    zip_stat_t st;
    zip_stat_init(&st);
    if (zip_stat_index(zip, static_cast<zip_uint64_t>(i), 0, &st) != 0 ||
        (st.valid & ZIP_STAT_NAME) == 0) {
      continue;
    }
    ArchiveMember m;
    m.name = st.name;
    m.size = (st.valid & ZIP_STAT_SIZE) != 0 ? st.size : 0;
    m.compressed = (st.valid & ZIP_STAT_COMP_SIZE) != 0 ? st.comp_size : 0;
    m.plate = plate_number(m.name);
    members.push_back(std::move(m));
  }
}

ZipArchive::ZipArchive(const std::string& path, std::string name, ArchiveLimits limits)
    : impl_(std::make_shared<Impl>()) {
  impl_->name = std::move(name);
  impl_->limits = limits;
  int err = 0;
  impl_->zip = zip_open(path.c_str(), ZIP_RDONLY, &err);
  if (impl_->zip == nullptr) {
    impl_->fail(fmt::format("found a damaged zip archive ({}), expected a 3MF archive",
                            zip_message(err)));
  }
  impl_->list();
}

ZipArchive::ZipArchive(std::FILE* file, std::string name, ArchiveLimits limits)
    : impl_(std::make_shared<Impl>()) {
  impl_->name = std::move(name);
  impl_->limits = limits;
  zip_error_t e;
  zip_error_init(&e);
  zip_source_t* src = zip_source_filep_create(file, 0, -1, &e);
  if (src == nullptr) {
    std::fclose(file);
    const std::string m = zip_error_strerror(&e);
    zip_error_fini(&e);
    impl_->fail(fmt::format("cannot read the zip archive ({})", m));
  }
  impl_->zip = zip_open_from_source(src, ZIP_RDONLY, &e);
  if (impl_->zip == nullptr) {
    zip_source_free(src);  // closes the file
    const std::string m = zip_error_strerror(&e);
    zip_error_fini(&e);
    impl_->fail(fmt::format("found a damaged zip archive ({}), expected a 3MF archive", m));
  }
  zip_error_fini(&e);
  impl_->list();
}

ZipArchive::~ZipArchive() = default;
ZipArchive::ZipArchive(ZipArchive&&) noexcept = default;
ZipArchive& ZipArchive::operator=(ZipArchive&&) noexcept = default;

std::vector<ArchiveMember> ZipArchive::gcode_members() const {
  std::vector<ArchiveMember> plates, others;
  for (const auto& m : impl_->members) {
    if (m.plate > 0) {
      plates.push_back(m);
    } else if (m.name.ends_with(".gcode") && !m.name.ends_with("/")) {
      others.push_back(m);
    }
  }
  if (!plates.empty()) {
    std::sort(plates.begin(), plates.end(),
              [](const ArchiveMember& a, const ArchiveMember& b) { return a.plate < b.plate; });
    return plates;
  }
  std::sort(others.begin(), others.end(),
            [](const ArchiveMember& a, const ArchiveMember& b) { return a.name < b.name; });
  return others;
}

bool ZipArchive::has_model() const {
  return std::any_of(impl_->members.begin(), impl_->members.end(), [](const ArchiveMember& m) {
    return m.name == "3D/3dmodel.model" || m.name.ends_with(".model");
  });
}

std::uint64_t ZipArchive::member_count() const { return impl_->members.size(); }

namespace {

class MemberSource final : public gcode::ByteSource {
 public:
  MemberSource(std::shared_ptr<ZipArchive::Impl> archive, zip_file_t* file, std::string name,
               std::string member, std::uint64_t size, bool member_in_origin)
      : archive_(std::move(archive)), file_(file), name_(std::move(name)),
        member_(std::move(member)), size_(size), member_in_origin_(member_in_origin) {}
  ~MemberSource() override { zip_fclose(file_); }
  MemberSource(const MemberSource&) = delete;
  MemberSource& operator=(const MemberSource&) = delete;

  std::size_t read(char* dst, std::size_t n) override {
    if (done_) return 0;
    const zip_int64_t got = zip_fread(file_, dst, n);
    if (got < 0) {
      throw Error(SourceLocation{name_, 0, 0},
                  fmt::format("{}: found damaged data ({}), expected the member as stored",
                              member_, zip_file_strerror(file_)));
    }
    read_ += static_cast<std::uint64_t>(got);
    if (read_ > size_) {
      throw Error(SourceLocation{name_, 0, 0},
                  fmt::format("{}: found more than the {} bytes its directory entry gives, "
                              "expected exactly that many (a zip bomb?)",
                              member_, size_));
    }
    if (got == 0) {
      done_ = true;
      if (read_ != size_) {
        throw Error(SourceLocation{name_, 0, 0},
                    fmt::format("{}: found {} bytes, expected the {} its directory entry gives "
                                "(a truncated archive?)",
                                member_, read_, size_));
      }
    }
    return static_cast<std::size_t>(got);
  }
  [[nodiscard]] std::string origin(std::uint64_t offset) const override {
    (void)offset;
    return member_in_origin_ ? member_ : std::string();
  }

 private:
  std::shared_ptr<ZipArchive::Impl> archive_;  // keeps the archive open
  zip_file_t* file_;
  std::string name_;
  std::string member_;
  std::uint64_t size_;
  bool member_in_origin_;
  std::uint64_t read_ = 0;
  bool done_ = false;
};

}  // namespace

std::unique_ptr<gcode::ByteSource> ZipArchive::open_member(const std::string& member,
                                                          bool member_in_origin) const {
  const Impl& a = *impl_;
  const auto it = std::find_if(a.members.begin(), a.members.end(),
                               [&](const ArchiveMember& m) { return m.name == member; });
  if (it == a.members.end()) {
    std::string names;
    for (const auto& m : gcode_members()) names += (names.empty() ? "" : ", ") + m.name;
    a.fail(fmt::format("found no member {}, expected one of the archive's G-code members ({})",
                       member, names.empty() ? "none" : names));
  }
  if (it->size > a.limits.max_member_bytes) {
    a.fail(fmt::format("{}: found {} bytes uncompressed, expected at most {}", member, it->size,
                       a.limits.max_member_bytes));
  }
  if (it->size > a.limits.ratio_floor_bytes &&
      static_cast<double>(it->size) > a.limits.max_ratio * static_cast<double>(it->compressed)) {
    a.fail(fmt::format("{}: found {} bytes stored as {} (a ratio of {:.0f}), expected at most "
                       "{:.0f} to 1 (a zip bomb?)",
                       member, it->size, it->compressed,
                       static_cast<double>(it->size) / std::max<double>(1.0, static_cast<double>(it->compressed)),
                       a.limits.max_ratio));
  }
  zip_file_t* f = zip_fopen(a.zip, member.c_str(), 0);
  if (f == nullptr) {
    a.fail(fmt::format("{}: cannot be read ({}), expected a stored or deflated member", member,
                       zip_strerror(a.zip)));
  }
  return std::make_unique<MemberSource>(impl_, f, a.name, member, it->size, member_in_origin);
}

bool is_zip(std::string_view prefix) {
  return prefix.starts_with(std::string_view("PK\x03\x04", 4)) ||
         prefix.starts_with(std::string_view("PK\x05\x06", 4));
}

}  // namespace amctl::formats
