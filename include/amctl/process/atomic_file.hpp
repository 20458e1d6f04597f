#pragma once
// Output that appears whole or not at all: written into a temporary file in the target's
// directory, flushed, then renamed over the target by commit(). A writer destroyed without
// commit() (an exception on the way) removes its temporary and leaves the target untouched,
// so the CLI never leaves a partial file behind. Streaming: memory does not grow with the
// output.
#include <string>
#include <string_view>

namespace amctl::process {

class AtomicFileWriter {
 public:
  /// Creates the temporary file; throws amctl::Error naming the directory when it cannot.
  explicit AtomicFileWriter(std::string path);
  ~AtomicFileWriter();
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;

  /// Appends bytes; throws amctl::Error (and removes the temporary) on a write error.
  void write(std::string_view bytes);
  /// fsync, close and rename onto the target; throws amctl::Error on failure.
  void commit();
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  [[noreturn]] void fail(const std::string& what);
  std::string path_;
  std::string tmp_;
  int fd_ = -1;
};

}  // namespace amctl::process
