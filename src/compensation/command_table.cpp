// The command table of `amctl compensate` (compensation/command_table.hpp).
#include "amctl/compensation/command_table.hpp"

#include <cstring>

#include "amctl/core/error.hpp"
#include "amctl/core/fixed_format.hpp"

namespace amctl::compensation {

CommandTable::CommandTable(std::string path, OutputOptions options)
    : format_(table_format_for(path)) {
  if (format_ == TableFormat::npy) {
    npy_.emplace(std::move(path), std::move(options));
  } else {
    csv_.emplace(std::move(path), std::move(options));
  }
}

void CommandTable::begin(bool with_accel) {
  AMCTL_CHECK(!begun_, "CommandTable::begin twice");
  begun_ = true;
  accel_ = with_accel;
  if (npy_) {
    std::vector<NpyColumn> cols;
    for (const char* n : {"time_s", "x_cmd_mm", "y_cmd_mm", "x_des_mm", "y_des_mm", "x_sim_mm", "y_sim_mm"})
      cols.push_back({n, NpyType::f8, 0});
    if (accel_) {
      cols.push_back({"x_cmd_accel_mm_s2", NpyType::f8, 0});
      cols.push_back({"y_cmd_accel_mm_s2", NpyType::f8, 0});
    }
    npy_->set_columns(std::move(cols));
  } else {
    buf_ = accel_ ? "time_s,x_cmd_mm,y_cmd_mm,x_des_mm,y_des_mm,x_sim_mm,y_sim_mm,x_cmd_accel_mm_s2,"
                    "y_cmd_accel_mm_s2\n"
                  : "time_s,x_cmd_mm,y_cmd_mm,x_des_mm,y_des_mm,x_sim_mm,y_sim_mm\n";
  }
}

void CommandTable::add(const CommandSample& s) {
  AMCTL_CHECK(begun_, "CommandTable::add before begin");
  const double v[9] = {s.t_s,      s.x_cmd_mm, s.y_cmd_mm, s.x_des_mm,          s.y_des_mm,
                       s.x_sim_mm, s.y_sim_mm, s.x_cmd_accel_mm_s2, s.y_cmd_accel_mm_s2};
  const std::size_t n = accel_ ? 9 : 7;
  if (npy_) {
    const std::size_t at = buf_.size();
    buf_.resize(at + n * sizeof(double));
    std::memcpy(buf_.data() + at, v, n * sizeof(double));
  } else {
    append_fixed(buf_, v[0], 9);
    for (std::size_t i = 1; i < 7; ++i) {
      buf_.push_back(',');
      append_fixed(buf_, v[i], 9);
    }
    for (std::size_t i = 7; i < n; ++i) {
      buf_.push_back(',');
      append_fixed(buf_, v[i], 6);
    }
    buf_.push_back('\n');
  }
  ++rows_;
  if (buf_.size() > (1U << 16)) flush();
}

void CommandTable::flush() {
  if (npy_) {
    npy_->append_records(buf_);
  } else {
    csv_->write(buf_);
  }
  buf_.clear();
}

void CommandTable::commit() {
  AMCTL_CHECK(begun_, "CommandTable::commit before begin");
  flush();
  if (npy_) {
    npy_->commit();
  } else {
    csv_->commit();
  }
}

}  // namespace amctl::compensation
