#pragma once
// The G-code inside a sliced 3MF (.gcode.3mf, as OrcaSlicer and Bambu Studio write it): a zip
// archive (read with libzip) whose plates are Metadata/plate_N.gcode, each a G-code text of its
// own. A 3MF without G-code is a 3D model: it has to be sliced first.
//
// Zip bombs: a member is read as a stream, never held whole, and its size is checked against
// ArchiveLimits before the first byte is read and while reading (a member that inflates past
// the size its directory entry gives stops with an error).
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "amctl/gcode/byte_source.hpp"

namespace amctl::formats {

struct ArchiveLimits {
  std::uint64_t max_members = 100000;            ///< entries in the archive's directory
  std::uint64_t max_member_bytes = 16ull << 30;  ///< one plate's G-code, uncompressed
  /// Largest uncompressed / compressed size of a member above ratio_floor_bytes: G-code
  /// deflates 3 to 10 times, a zip bomb thousands of times.
  double max_ratio = 200.0;
  std::uint64_t ratio_floor_bytes = 16u << 20;
};

/// One member of the archive.
struct ArchiveMember {
  std::string name;              ///< "Metadata/plate_1.gcode"
  std::uint64_t size = 0;        ///< uncompressed [bytes], as the directory gives it
  std::uint64_t compressed = 0;  ///< stored [bytes]
  int plate = 0;                 ///< N of Metadata/plate_N.gcode, 0 for another name
};

class ZipArchive {
 public:
  /// Opens the zip file at `path`; `name` is used in messages.
  ZipArchive(const std::string& path, std::string name, ArchiveLimits limits = {});
  /// Opens a zip held in `file` (a spooled copy of standard input), which it then owns.
  ZipArchive(std::FILE* file, std::string name, ArchiveLimits limits = {});
  ~ZipArchive();
  ZipArchive(ZipArchive&&) noexcept;
  ZipArchive& operator=(ZipArchive&&) noexcept;

  /// The G-code members: the plates Metadata/plate_N.gcode by N; if there are none, every
  /// member whose name ends in ".gcode", by name.
  [[nodiscard]] std::vector<ArchiveMember> gcode_members() const;
  /// True if the archive holds a 3MF model part (3D/3dmodel.model).
  [[nodiscard]] bool has_model() const;
  [[nodiscard]] std::uint64_t member_count() const;
  /// A member's bytes, streamed. Throws amctl::Error if it is missing or breaks a limit.
  /// The source keeps the archive open; its origin() names the member when
  /// `member_in_origin` (messages then read "archive.3mf:12:5: ... (in Metadata/plate_1.gcode)").
  [[nodiscard]] std::unique_ptr<gcode::ByteSource> open_member(const std::string& member,
                                                               bool member_in_origin = true) const;

  struct Impl;  ///< opaque (the open libzip archive)

 private:
  std::shared_ptr<Impl> impl_;
};

/// True if `prefix` (the first bytes of a file) starts like a zip archive.
bool is_zip(std::string_view prefix);

}  // namespace amctl::formats
