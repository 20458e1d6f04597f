// The steps CSV through amctl::OutputFile, written whole or not at all.
#include <iterator>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/steppers/steps.hpp"

namespace amctl::steppers {


StepsCsvFile::StepsCsvFile(std::string path, std::vector<std::string> names, OutputOptions options)
    : out_(std::move(path), std::move(options)), names_(std::move(names)) {
  buf_ = "stepper,time_s,direction\n";
  bytes_ = buf_.size();
}

void StepsCsvFile::flush() {
  out_.write(buf_);
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
  out_.commit();
}

}  // namespace amctl::steppers
