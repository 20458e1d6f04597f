// The steps CSV, written whole or not at all.
#include <iterator>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/steppers/steps.hpp"

namespace amctl::steppers {


StepsCsvFile::StepsCsvFile(std::string path, std::vector<std::string> names)
    : path_(std::move(path)), tmp_(path_ + ".part"), names_(std::move(names)) {
  file_ = std::fopen(tmp_.c_str(), "wb");
  if (file_ == nullptr) throw Error(fmt::format("cannot write CSV file '{}'", path_));
  buf_ = "stepper,time_s,direction\n";
  bytes_ = buf_.size();
}

StepsCsvFile::~StepsCsvFile() {
  if (file_ != nullptr) std::fclose(file_);
  if (!committed_) std::remove(tmp_.c_str());
}

void StepsCsvFile::flush() {
  if (!buf_.empty() && std::fwrite(buf_.data(), 1, buf_.size(), file_) != buf_.size()) {
    throw Error(fmt::format("cannot write CSV file '{}' (disk full?)", path_));
  }
  buf_.clear();
}

void StepsCsvFile::write(std::span<const Step> steps) {
  const std::size_t before = buf_.size();
  auto it = std::back_inserter(buf_);
  for (const Step& s : steps) {
    // "{}" is the shortest form that reads back to the same double.
    fmt::format_to(it, "{},{},{}\n", names_[s.stepper], s.time_s, s.direction);
  }
  rows_ += steps.size();
  bytes_ += buf_.size() - before;
  if (buf_.size() > (1u << 20)) flush();
}

void StepsCsvFile::commit() {
  flush();
  const bool ok = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!ok || std::rename(tmp_.c_str(), path_.c_str()) != 0) {
    throw Error(fmt::format("cannot write CSV file '{}'", path_));
  }
  committed_ = true;
}

}  // namespace amctl::steppers
