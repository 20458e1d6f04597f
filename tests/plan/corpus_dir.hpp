#pragma once
// Where the shared corpus of real slicer files is. It lives beside the clone
// (../shared/corpus); a git worktree sits one level deeper (e.g. wt/NAME beside shared/), and
// looking only at ../shared skipped the corpus tests there without a word. Looks in
// $AMCTL_CORPUS_DIR first, then in shared/corpus of each of the three nearest ancestors of the
// source tree.
#include <cstdlib>
#include <filesystem>
#include <optional>

namespace amctl::test {

inline std::optional<std::filesystem::path> corpus_dir() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("AMCTL_CORPUS_DIR"); env != nullptr && fs::is_directory(env)) {
    return fs::path(env);
  }
  fs::path dir = fs::weakly_canonical(fs::path(AMCTL_SOURCE_DIR));
  for (int up = 0; up < 3 && dir.has_parent_path() && dir != dir.parent_path(); ++up) {
    dir = dir.parent_path();
    if (fs::is_directory(dir / "shared" / "corpus" / "gcode")) return dir / "shared" / "corpus";
  }
  return std::nullopt;
}

}  // namespace amctl::test
