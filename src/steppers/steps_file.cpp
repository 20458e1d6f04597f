// The steps table (CSV or .npy) through amctl::OutputFile, written whole or not at all.
#include <algorithm>
#include <cstring>
#include <iterator>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/steppers/steps.hpp"

namespace amctl::steppers {

namespace {

std::vector<NpyColumn> steps_columns(const std::vector<std::string>& names) {
  std::size_t width = 1;
  for (const std::string& n : names) width = std::max(width, n.size());
  return {{"stepper", NpyType::text, width}, {"time_s", NpyType::f8, 0}, {"direction", NpyType::i1, 0}};
}

}  // namespace

StepsFile::StepsFile(std::string path, std::vector<std::string> names, OutputOptions options)
    : format_(table_format_for(path)), names_(std::move(names)) {
  if (format_ == TableFormat::npy) {
    npy_.emplace(std::move(path), steps_columns(names_), std::move(options));
    bytes_ = npy_->bytes();
  } else {
    csv_.emplace(std::move(path), std::move(options));
    buf_ = "stepper,time_s,direction\n";
    bytes_ = buf_.size();
  }
}

void StepsFile::flush() {
  if (npy_) {
    npy_->append_records(buf_);
  } else {
    csv_->write(buf_);
  }
  buf_.clear();
}

void StepsFile::write(std::span<const Step> steps) {
  const std::size_t before = buf_.size();
  if (npy_) {
    // One record: the name padded with NUL to the column's width, the time, the direction.
    const std::size_t width = npy_->columns()[0].text_bytes;
    const std::size_t rec = npy_->record_bytes();
    buf_.resize(before + steps.size() * rec, '\0');
    char* at = buf_.data() + before;
    for (const Step& s : steps) {
      const std::string& name = names_[s.stepper];
      std::memcpy(at, name.data(), name.size());
      std::memcpy(at + width, &s.time_s, sizeof s.time_s);
      at[width + 8] = static_cast<char>(static_cast<std::int8_t>(s.direction));
      at += rec;
    }
  } else {
    auto it = std::back_inserter(buf_);
    for (const Step& s : steps) {
      // "{}" is the shortest form that reads back to the same double.
      fmt::format_to(it, "{},{},{}\n", names_[s.stepper], s.time_s, s.direction);
    }
  }
  rows_ += steps.size();
  bytes_ += buf_.size() - before;
  if (buf_.size() > (1u << 20)) flush();
}

void StepsFile::commit() {
  flush();
  if (npy_) {
    npy_->commit();
  } else {
    csv_->commit();
  }
}

}  // namespace amctl::steppers
