#include "amctl/process/atomic_file.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <vector>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::process {

AtomicFileWriter::AtomicFileWriter(std::string path) : path_(std::move(path)) {
  namespace fs = std::filesystem;
  const fs::path target(path_);
  fs::path dir = target.parent_path();
  if (dir.empty()) dir = ".";
  const std::string tmpl = (dir / ("." + target.filename().string() + ".tmp.XXXXXX")).string();
  std::vector<char> buf(tmpl.begin(), tmpl.end());
  buf.push_back('\0');
  fd_ = ::mkstemp(buf.data());
  if (fd_ < 0) {
    throw Error(fmt::format("cannot create a temporary file in '{}' for output '{}': {}",
                            dir.string(), path_, std::strerror(errno)));
  }
  tmp_ = buf.data();
}

AtomicFileWriter::~AtomicFileWriter() {
  if (fd_ >= 0) {
    ::close(fd_);
    ::unlink(tmp_.c_str());
  }
}

void AtomicFileWriter::fail(const std::string& what) {
  const int err = errno;
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  ::unlink(tmp_.c_str());
  throw Error(fmt::format("cannot write output '{}' ({}): {}", path_, what, std::strerror(err)));
}

void AtomicFileWriter::write(std::string_view bytes) {
  AMCTL_CHECK(fd_ >= 0, "AtomicFileWriter::write after commit or failure");
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t w = ::write(fd_, bytes.data() + done, bytes.size() - done);
    if (w < 0) {
      if (errno == EINTR) continue;
      fail("write");
    }
    done += static_cast<std::size_t>(w);
  }
}

void AtomicFileWriter::commit() {
  AMCTL_CHECK(fd_ >= 0, "AtomicFileWriter::commit twice or after a failure");
  if (::fsync(fd_) != 0) fail("fsync");
  ::fchmod(fd_, 0644);
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp_.c_str());
    throw Error(fmt::format("cannot write output '{}' (close): {}", path_, std::strerror(err)));
  }
  if (std::rename(tmp_.c_str(), path_.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp_.c_str());
    throw Error(fmt::format("cannot rename temporary file onto '{}': {}", path_, std::strerror(err)));
  }
}

}  // namespace amctl::process
