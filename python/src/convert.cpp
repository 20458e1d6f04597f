#include "amctl/core/error.hpp"
#include "common.hpp"

namespace amctl::py_bind {

py::object to_python(const Json& j) {
  switch (j.type()) {
    case Json::value_t::null: return py::none();
    case Json::value_t::boolean: return py::bool_(j.get<bool>());
    case Json::value_t::number_integer: return py::int_(j.get<std::int64_t>());
    case Json::value_t::number_unsigned: return py::int_(j.get<std::uint64_t>());
    case Json::value_t::number_float: return py::float_(j.get<double>());
    case Json::value_t::string: return py::str(j.get_ref<const std::string&>());
    case Json::value_t::array: {
      py::list out(j.size());
      std::size_t i = 0;
      for (const Json& v : j) out[i++] = to_python(v);
      return out;
    }
    case Json::value_t::object: {
      py::dict out;
      for (auto it = j.begin(); it != j.end(); ++it) out[py::str(it.key())] = to_python(it.value());
      return out;
    }
    case Json::value_t::binary:
    case Json::value_t::discarded: break;
  }
  return py::none();
}

plan::FileLimits file_limits_arg(const std::string& value) {
  if (const auto f = plan::parse_file_limits(value)) return *f;
  throw Error("file_limits: found '" + value + "', expected one of keep, ignore, cap");
}

}  // namespace amctl::py_bind
