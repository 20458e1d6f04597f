#include "amctl/macro/value.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>

#include "amctl/core/error.hpp"

namespace amctl::macro {

namespace {
constexpr std::size_t kIndexFrom = 16;  // items before a hash index pays off
}  // namespace

const Value* Dict::find(std::string_view key) const {
  if (!index_.empty()) {
    const auto it = index_.find(std::string(key));
    return it == index_.end() ? nullptr : &items[it->second].second;
  }
  for (const auto& [k, v] : items) {
    if (k == key) return &v;
  }
  return nullptr;
}

void Dict::set(std::string key, Value v) {
  if (!index_.empty()) {
    const auto it = index_.find(key);
    if (it != index_.end()) {
      items[it->second].second = std::move(v);
      return;
    }
    index_.emplace(key, items.size());
    items.emplace_back(std::move(key), std::move(v));
    return;
  }
  for (auto& [k, old] : items) {
    if (k == key) {
      old = std::move(v);
      return;
    }
  }
  items.emplace_back(std::move(key), std::move(v));
  if (items.size() >= kIndexFrom) {
    for (std::size_t i = 0; i < items.size(); ++i) index_.emplace(items[i].first, i);
  }
}

namespace {

constexpr std::uint64_t kSaturated = std::uint64_t{1} << 62;

std::uint64_t add_sat(std::uint64_t a, std::uint64_t b) { return a + b >= kSaturated ? kSaturated : a + b; }

}  // namespace

Value Value::undefined(std::string what) {
  Value v;
  v.s_ = std::move(what);
  v.footprint_ = add_sat(16, v.s_.size());
  return v;
}
Value Value::none() {
  Value v;
  v.type_ = Type::none;
  return v;
}
Value Value::boolean(bool b) {
  Value v;
  v.type_ = Type::boolean;
  v.b_ = b;
  v.i_ = b ? 1 : 0;
  v.d_ = b ? 1.0 : 0.0;
  return v;
}
Value Value::integer(std::int64_t i) {
  Value v;
  v.type_ = Type::integer;
  v.i_ = i;
  v.d_ = static_cast<double>(i);
  return v;
}
Value Value::number(double d) {
  Value v;
  v.type_ = Type::number;
  v.d_ = d;
  return v;
}
Value Value::string(std::string s) {
  Value v;
  v.type_ = Type::string;
  v.s_ = std::move(s);
  v.footprint_ = add_sat(16, v.s_.size());
  return v;
}
Value Value::list(List items, bool coord, bool tuple) {
  Value v;
  v.type_ = Type::list;
  v.tuple_ = tuple || coord;
  for (const Value& e : items) {
    v.depth_ = std::max(v.depth_, e.depth_ + 1);
    v.footprint_ = add_sat(v.footprint_, e.footprint_);
  }
  if (items.empty()) v.depth_ = 1;
  v.list_ = std::make_shared<const List>(std::move(items));
  v.coord_ = coord;
  return v;
}
Value Value::dict(Dict d) {
  Value v;
  v.type_ = Type::dict;
  v.depth_ = 1;
  for (const auto& [k, e] : d.items) {
    v.depth_ = std::max(v.depth_, e.depth_ + 1);
    v.footprint_ = add_sat(v.footprint_, add_sat(16 + k.size(), e.footprint_));
  }
  v.dict_ = std::make_shared<const Dict>(std::move(d));
  return v;
}
Value Value::function(std::string name, std::shared_ptr<const Value> self) {
  Value v;
  v.type_ = Type::function;
  v.s_ = std::move(name);
  v.footprint_ = add_sat(16, v.s_.size());
  v.self_ = std::move(self);
  return v;
}

double Value::to_double() const { return d_; }

const List& Value::items() const {
  static const List kEmpty;
  return list_ ? *list_ : kEmpty;
}

const Dict& Value::entries() const {
  static const Dict kEmpty;
  return dict_ ? *dict_ : kEmpty;
}

bool Value::truthy() const {
  switch (type_) {
    case Type::undefined:
    case Type::none: return false;
    case Type::boolean: return b_;
    case Type::integer: return i_ != 0;
    case Type::number: return d_ != 0.0;
    case Type::string: return !s_.empty();
    case Type::list: return !items().empty();
    case Type::dict: return !entries().items.empty();
    case Type::function: return true;
  }
  return false;
}

std::string python_float_repr(double x) {
  if (std::isnan(x)) return "nan";
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, x, std::chars_format::scientific);
  std::string_view sci(buf, static_cast<std::size_t>(res.ptr - buf));
  std::string out;
  if (sci.front() == '-') {
    out = "-";
    sci.remove_prefix(1);
  }
  const std::size_t e = sci.find('e');
  std::string digits;
  for (char c : sci.substr(0, e)) {
    if (c != '.') digits += c;
  }
  const int exp = std::atoi(std::string(sci.substr(e + 1)).c_str());
  if (exp >= -4 && exp < 16) {
    if (exp >= 0) {
      const auto int_len = static_cast<std::size_t>(exp) + 1;
      if (digits.size() <= int_len) {
        out += digits + std::string(int_len - digits.size(), '0') + ".0";
      } else {
        out += digits.substr(0, int_len) + "." + digits.substr(int_len);
      }
    } else {
      out += "0." + std::string(static_cast<std::size_t>(-exp - 1), '0') + digits;
    }
    return out;
  }
  out += digits.substr(0, 1);
  if (digits.size() > 1) out += "." + digits.substr(1);
  out += exp < 0 ? "e-" : "e+";
  const int a = exp < 0 ? -exp : exp;
  if (a < 10) out += '0';
  out += std::to_string(a);
  return out;
}

std::string Value::str() const {
  switch (type_) {
    case Type::undefined: return "";
    case Type::none: return "None";
    case Type::boolean: return b_ ? "True" : "False";
    case Type::integer: return std::to_string(i_);
    case Type::number: return python_float_repr(d_);
    case Type::string: return s_;
    case Type::list: {
      std::string out = tuple_ ? "(" : "[";
      bool first = true;
      for (const Value& v : items()) {
        if (!first) out += ", ";
        first = false;
        out += v.repr();
      }
      if (tuple_ && items().size() == 1) out += ",";
      return out + (tuple_ ? ")" : "]");
    }
    case Type::dict: {
      std::string out = "{";
      bool first = true;
      for (const auto& [k, v] : entries().items) {
        if (!first) out += ", ";
        first = false;
        out += Value::string(k).repr() + ": " + v.repr();
      }
      return out + "}";
    }
    case Type::function: return "<built-in function " + s_ + ">";
  }
  return "";
}

std::string Value::repr() const {
  if (type_ != Type::string) return str();
  // Python quotes with ' unless the text holds ' and no ".
  const bool dq = s_.find('\'') != std::string::npos && s_.find('"') == std::string::npos;
  const char q = dq ? '"' : '\'';
  std::string out(1, q);
  for (char c : s_) {
    if (c == '\\') out += "\\\\";
    else if (c == '\n') out += "\\n";
    else if (c == '\t') out += "\\t";
    else if (c == q) out += std::string("\\") + q;
    else out += c;
  }
  return out + q;
}

bool operator==(const Value& a, const Value& b) {
  using T = Value::Type;
  if (a.is_number() && b.is_number()) {
    if (a.type_ != T::number && b.type_ != T::number) return a.i_ == b.i_;
    return a.d_ == b.d_;
  }
  if (a.type_ != b.type_) return false;
  switch (a.type_) {
    case T::undefined:
    case T::none: return true;
    case T::string:
    case T::function: return a.s_ == b.s_;
    case T::list: {
      if (a.tuple_ != b.tuple_) return false;  // Python: (1, 2) != [1, 2]
      const List& x = a.items();
      const List& y = b.items();
      if (x.size() != y.size()) return false;
      for (std::size_t i = 0; i < x.size(); ++i) {
        if (!(x[i] == y[i])) return false;
      }
      return true;
    }
    case T::dict: {
      const Dict& x = a.entries();
      const Dict& y = b.entries();
      if (x.items.size() != y.items.size()) return false;
      for (const auto& [k, v] : x.items) {
        const Value* w = y.find(k);
        if (w == nullptr || !(v == *w)) return false;
      }
      return true;
    }
    default: return false;
  }
}

std::string_view Value::type_name() const {
  switch (type_) {
    case Type::undefined: return "Undefined";
    case Type::none: return "NoneType";
    case Type::boolean: return "bool";
    case Type::integer: return "int";
    case Type::number: return "float";
    case Type::string: return "str";
    case Type::list: return "list";
    case Type::dict: return "dict";
    case Type::function: return "function";
  }
  return "?";
}

}  // namespace amctl::macro
