// Syntax tree -> text. Values follow Jinja2 on Python 3 (jinja2/runtime.py Undefined,
// jinja2/filters.py, jinja2/tests.py): an undefined value renders as "", is false and
// iterates as empty, and fails in arithmetic; `/` is true division, `//` and `%` floor;
// filters and tests as listed in docs/macros.md.
#include <algorithm>
#include <cctype>
#include <optional>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include <fmt/format.h>

#include "amctl/macro/template.hpp"
#include "ast.hpp"

namespace amctl::macro {
namespace detail {
std::shared_ptr<const Body> parse_template(std::string_view text);
ExprPtr parse_expression(std::string_view text);

namespace {

using T = Value::Type;

std::string_view trim_ws(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

/// Python float(str): decimal or exponent form, inf/nan, surrounding whitespace.
bool parse_python_float(std::string_view s, double& out) {
  s = trim_ws(s);
  if (s.empty()) return false;
  std::string t;
  for (char c : s) {
    if (c != '_') t += c;
  }
  std::string_view body = t;
  if (!body.empty() && (body.front() == '+' || body.front() == '-')) body.remove_prefix(1);
  if (body.empty()) return false;
  for (char c : body) {  // reject hexadecimal, which strtod would take
    if (c == 'x' || c == 'X' || c == 'p' || c == 'P') return false;
  }
  char* end = nullptr;
  out = std::strtod(t.c_str(), &end);
  return end == t.c_str() + t.size();
}

/// Python int(str): optional sign, decimal digits (underscores between them).
bool parse_python_int(std::string_view s, std::int64_t& out) {
  s = trim_ws(s);
  std::string t;
  for (char c : s) {
    if (c != '_') t += c;
  }
  const char* b = t.data();
  if (!t.empty() && t.front() == '+') ++b;
  const auto r = std::from_chars(b, t.data() + t.size(), out);
  return !t.empty() && r.ec == std::errc() && r.ptr == t.data() + t.size();
}

class Renderer {
 public:
  Renderer(const Dict& globals, const RenderLimits& limits) : globals_(globals), limits_(limits) {}

  void run(const NodeList& nodes) {
    for (const Node& n : nodes) node(n);
  }
  std::string& output() { return out_; }

 private:
  [[noreturn]] static void fail(std::uint32_t line, const std::string& msg) {
    throw TemplateError(line, msg);
  }

  void emit(std::string_view s, std::uint32_t line) {
    if (out_.size() + s.size() > limits_.max_output_bytes) {
      limit(line, fmt::format("output limit: the render writes more than {} bytes, expected at most {}",
                              limits_.max_output_bytes, limits_.max_output_bytes));
    }
    work(s.size(), line);
    out_ += s;
  }

  // ---- limits (RenderLimits; docs/macros.md, "Limits") ----
  [[noreturn]] static void limit(std::uint32_t line, const std::string& msg) { throw LimitError(line, msg); }

  /// Work: one per expression node, one per item or byte compared, scanned or copied.
  void work(std::uint64_t n, std::uint32_t line) {
    work_ += n;
    if (work_ > limits_.max_work) {
      limit(line, fmt::format("work limit: the render takes more than {} steps (expression nodes, items "
                              "and bytes compared, scanned or copied), expected at most {}",
                              limits_.max_work, limits_.max_work));
    }
  }
  /// Memory: bytes of strings and lists built.
  void allocate(std::uint64_t bytes, std::uint32_t line) {
    allocated_ += bytes;
    if (allocated_ > limits_.max_allocated_bytes) {
      limit(line, fmt::format("memory limit: the render builds more than {} MiB of strings and lists, "
                              "expected at most {} MiB",
                              limits_.max_allocated_bytes >> 20, limits_.max_allocated_bytes >> 20));
    }
  }
  void check_string_size(std::uint64_t bytes, std::uint32_t line) const {
    if (bytes > limits_.max_string_bytes) {
      limit(line, fmt::format("string limit: found a string of {} bytes, expected at most {}", bytes,
                              limits_.max_string_bytes));
    }
  }
  void check_list_size(std::uint64_t items, std::uint32_t line) const {
    if (items > limits_.max_list_length) {
      limit(line, fmt::format("list limit: found a list or dict of {} items, expected at most {}", items,
                              limits_.max_list_length));
    }
  }
  /// Every value an expression yields: within the size and nesting bounds.
  void check_value(const Value& v, std::uint32_t line) const {
    if (v.type() == T::string) check_string_size(v.text().size(), line);
    if (v.type() == T::list) check_list_size(v.items().size(), line);
    if (v.type() == T::dict) check_list_size(v.entries().items.size(), line);
    if (v.footprint() > limits_.max_value_bytes) {
      limit(line, fmt::format("value limit: found a value of more than {} MiB (counted as printed, a shared "
                              "item each time), expected at most {} MiB",
                              limits_.max_value_bytes >> 20, limits_.max_value_bytes >> 20));
    }
    if (v.depth() > kMaxValueDepth) {
      limit(line, fmt::format("nesting limit: found lists or dicts nested more than {} deep, expected at "
                              "most {}",
                              kMaxValueDepth, kMaxValueDepth));
    }
  }
  /// A copy of the items of a list (or the characters of a string, the keys of a dict), charged.
  List copy_items(const Value& v, std::uint32_t line) {
    std::uint64_t n = 0;
    switch (v.type()) {
      case T::list: n = v.items().size(); break;
      case T::dict: n = v.entries().items.size(); break;
      case T::string: n = v.text().size(); break;
      default: break;
    }
    check_list_size(n, line);
    work(n + v.footprint() / 16, line);
    allocate(n * sizeof(Value) + v.footprint(), line);
    return sequence(v, line);
  }
  /// str() of a value, its cost charged and its length bounded.
  std::string str_of(const Value& v, std::uint32_t line) {
    work(v.footprint(), line);
    std::string s = v.str();
    check_string_size(s.size(), line);
    allocate(s.size(), line);
    return s;
  }

  // ---- names ----
  const Value* lookup(const std::string& name) const {
    for (auto f = frames_.rbegin(); f != frames_.rend(); ++f) {
      if (const Value* v = f->find(name)) return v;
    }
    return globals_.find(name);
  }
  void assign(const std::string& name, Value v) {
    if (frames_.empty()) {
      top_.set(name, std::move(v));
    } else {
      frames_.back().set(name, std::move(v));
    }
  }

  // ---- statements ----
  void node(const Node& n) {
    switch (n.kind) {
      case Node::Kind::text: emit(n.text, n.line); return;
      case Node::Kind::output: {
        const Value v = eval(*n.expr);
        if (v.type() == T::string) {
          emit(v.text(), n.line);
        } else {
          emit(str_of(v, n.line), n.line);
        }
        return;
      }
      case Node::Kind::if_:
        for (const auto& [cond, body] : n.branches) {
          if (eval(*cond).truthy()) {
            run(body);
            return;
          }
        }
        run(n.else_body);
        return;
      case Node::Kind::for_: loop(n); return;
      case Node::Kind::set: set(n); return;
    }
  }

  void set(const Node& n) {
    Value v = eval(*n.expr);
    if (n.attr_target) {  // {% set ns.attr = v %} on a namespace(): rebind where ns lives
      const Value* ns = lookup(n.targets[0]);
      if (ns == nullptr || ns->type() != T::dict) {
        fail(n.line, fmt::format("'{}' is not a namespace", n.targets[0]));
      }
      work(ns->entries().items.size() + 1, n.line);
      allocate(ns->footprint(), n.line);
      Dict d = ns->entries();
      if (v.depth() + 1 > kMaxValueDepth) {
        limit(n.line, fmt::format("nesting limit: found lists or dicts nested more than {} deep, expected at "
                                  "most {}",
                                  kMaxValueDepth, kMaxValueDepth));
      }
      d.set(n.targets[1], std::move(v));
      for (auto f = frames_.rbegin(); f != frames_.rend(); ++f) {
        if (f->find(n.targets[0]) != nullptr) {
          f->set(n.targets[0], Value::dict(std::move(d)));
          return;
        }
      }
      top_.set(n.targets[0], Value::dict(std::move(d)));
      return;
    }
    unpack(n.targets, std::move(v), n.line);
  }

  void unpack(const std::vector<std::string>& targets, Value v, std::uint32_t line) {
    if (targets.size() == 1) {
      assign(targets[0], std::move(v));
      return;
    }
    if (v.type() != T::list || v.items().size() != targets.size()) {
      fail(line, fmt::format("cannot unpack {} into {} names",
                             v.footprint() > 200 ? std::string("a ") + std::string(v.type_name()) : v.repr(),
                             targets.size()));
    }
    for (std::size_t i = 0; i < targets.size(); ++i) assign(targets[i], v.items()[i]);
  }

  void loop(const Node& n) {
    // The sequence is held (a list or dict shares its items, a string is one copy) and each
    // item made as the loop reaches it: nothing the size of the sequence is built.
    const Value seq = eval(*n.expr);
    std::size_t count = 0;
    switch (seq.type()) {
      case T::undefined: break;
      case T::list: count = seq.items().size(); break;
      case T::dict: count = seq.entries().items.size(); break;
      case T::string: count = seq.text().size(); break;
      default: fail(n.line, fmt::format("'{}' object is not iterable", seq.type_name()));
    }
    auto item = [&seq](std::size_t i) {
      switch (seq.type()) {
        case T::list: return seq.items()[i];
        case T::dict: return Value::string(seq.entries().items[i].first);
        default: return Value::string(std::string(1, seq.text()[i]));
      }
    };
    if (count == 0) {
      run(n.else_body);
      return;
    }
    const auto length = static_cast<std::int64_t>(count);
    for (std::int64_t i = 0; i < length; ++i) {
      if (++iterations_ > limits_.max_loop_iterations) {
        limit(n.line, fmt::format("loop limit: the render makes more than {} loop iterations, expected at "
                                  "most {}",
                                  limits_.max_loop_iterations, limits_.max_loop_iterations));
      }
      work(8, n.line);
      frames_.emplace_back();  // a loop body is a scope of its own (Jinja)
      Dict info;
      info.set("index", Value::integer(i + 1));
      info.set("index0", Value::integer(i));
      info.set("revindex", Value::integer(length - i));
      info.set("revindex0", Value::integer(length - i - 1));
      info.set("first", Value::boolean(i == 0));
      info.set("last", Value::boolean(i == length - 1));
      info.set("length", Value::integer(length));
      frames_.back().set("loop", Value::dict(std::move(info)));
      unpack(n.targets, item(static_cast<std::size_t>(i)), n.line);
      run(n.branches.front().second);
      frames_.pop_back();
    }
  }

  // ---- expressions ----
  static std::string describe(const Expr& e) {
    switch (e.kind) {
      case Expr::Kind::name: return e.text;
      case Expr::Kind::attr: return describe(*e.args[0]) + "." + e.text;
      case Expr::Kind::item: {
        const Expr& k = *e.args[1];
        return describe(*e.args[0]) + "[" + (k.kind == Expr::Kind::literal ? k.value.repr() : "...") + "]";
      }
      default: return "the value";
    }
  }

  [[noreturn]] static void undefined_error(const Value& v, std::uint32_t line) {
    const bool printer = v.text().rfind("printer", 0) == 0 && v.text() != "printer";
    fail(line, fmt::format("'{}' is undefined{}", v.text(),
                           printer ? " (a printer object or field amctl does not model)" : ""));
  }

  /// Values nested deeper than this (a list built into itself in a loop) are an error.
  static constexpr std::uint32_t kMaxValueDepth = 100;

  Value eval(const Expr& e) {
    work(1, e.line);
    Value v = eval_unchecked(e);
    check_value(v, e.line);
    if (v.type() == T::string) allocate(v.text().size(), e.line);  // strings are copied by value
    return v;
  }

  Value eval_unchecked(const Expr& e) {
    switch (e.kind) {
      case Expr::Kind::literal: return e.value;
      case Expr::Kind::name: {
        if (const Value* v = lookup(e.text)) return *v;
        if (e.text == "range" || e.text == "namespace") return Value::function(e.text);
        return Value::undefined(e.text);
      }
      case Expr::Kind::attr: return attribute(eval(*e.args[0]), e.text, describe(e), e.line);
      case Expr::Kind::item: {
        const Value obj = eval(*e.args[0]);
        const Value key = eval(*e.args[1]);
        return item(obj, key, describe(e), e.line);
      }
      case Expr::Kind::call: return call(e);
      case Expr::Kind::filter: return filter(e);
      case Expr::Kind::test: return Value::boolean(test(e) != e.negated);
      case Expr::Kind::unary: {
        const Value v = eval(*e.args[0]);
        if (e.text == "not") return Value::boolean(!v.truthy());
        if (v.is_undefined()) undefined_error(v, e.line);
        if (!v.is_number()) fail(e.line, fmt::format("bad operand type for unary {}: '{}'", e.text, v.type_name()));
        if (e.text == "+") return v.type() == T::boolean ? Value::integer(v.as_int()) : v;
        if (v.type() == T::number) return Value::number(-v.to_double());
        if (v.as_int() == std::numeric_limits<std::int64_t>::min()) fail(e.line, "integer overflow");
        return Value::integer(-v.as_int());
      }
      case Expr::Kind::binary: {
        const Value a = eval(*e.args[0]);
        const Value b = eval(*e.args[1]);
        return binary(e.text, a, b, e.line);
      }
      case Expr::Kind::compare: {
        Value left = eval(*e.args[0]);
        for (std::size_t i = 0; i < e.ops.size(); ++i) {
          Value right = eval(*e.args[i + 1]);
          work(std::min(left.footprint(), right.footprint()) +
                   (e.ops[i] == "in" || e.ops[i] == "notin" ? right.footprint() * std::max<std::uint64_t>(1, left.footprint()) / 16 : 0),
               e.line);
          if (!compare(e.ops[i], left, right, e.line)) return Value::boolean(false);
          left = std::move(right);
        }
        return Value::boolean(true);
      }
      case Expr::Kind::logic: {
        Value l = eval(*e.args[0]);
        if (e.text == "and") return l.truthy() ? eval(*e.args[1]) : l;
        return l.truthy() ? l : eval(*e.args[1]);
      }
      case Expr::Kind::cond:
        if (eval(*e.args[0]).truthy()) return eval(*e.args[1]);
        return e.args.size() > 2 ? eval(*e.args[2]) : Value::undefined("the else branch");
      case Expr::Kind::list: {
        List l;
        for (const auto& a : e.args) l.push_back(eval(*a));
        allocate(l.size() * sizeof(Value), e.line);
        return Value::list(std::move(l), false, e.tuple);
      }
      case Expr::Kind::dict: {
        Dict d;
        for (std::size_t i = 0; i < e.args.size(); ++i) {
          const Value k = eval(*e.keys[i]);
          if (k.type() != T::string) fail(e.line, "dict keys must be strings here");
          d.set(k.text(), eval(*e.args[i]));
        }
        return Value::dict(std::move(d));
      }
    }
    fail(e.line, "unknown expression");
  }

  static Value attribute(const Value& obj, const std::string& name, const std::string& what,
                         std::uint32_t line) {
    switch (obj.type()) {
      case T::undefined: undefined_error(obj, line);
      case T::dict: {
        if (const Value* v = obj.entries().find(name)) return *v;
        if (name == "get" || name == "keys" || name == "values" || name == "items") {
          return Value::function(name, std::make_shared<const Value>(obj));
        }
        return Value::undefined(what);
      }
      case T::list:
        if (obj.is_coord() && name.size() == 1) {
          const std::size_t i = std::string_view("xyze").find(name[0]);
          if (i != std::string_view::npos && i < obj.items().size()) return obj.items()[i];
        }
        return Value::undefined(what);
      case T::string: {
        static constexpr std::string_view kMethods[] = {
            "lower", "upper", "strip", "lstrip", "rstrip", "split", "startswith",
            "endswith", "replace", "capitalize", "title", "isdigit"};
        for (std::string_view m : kMethods) {
          if (name == m) return Value::function(name, std::make_shared<const Value>(obj));
        }
        return Value::undefined(what);
      }
      case T::integer:
      case T::number:
        if (name == "is_integer" && obj.type() == T::number) {
          return Value::function(name, std::make_shared<const Value>(obj));
        }
        return Value::undefined(what);
      default: return Value::undefined(what);
    }
  }

  static Value item(const Value& obj, const Value& key, const std::string& what,
                    std::uint32_t line) {
    switch (obj.type()) {
      case T::undefined: undefined_error(obj, line);
      case T::dict:
        if (key.type() == T::string) {
          if (const Value* v = obj.entries().find(key.text())) return *v;
        }
        return Value::undefined(what);
      case T::list:
      case T::string: {
        if (key.type() != T::integer && key.type() != T::boolean) {
          if (key.type() == T::string) return attribute(obj, key.text(), what, line);
          fail(line, fmt::format("indices must be integers, not {}", key.type_name()));
        }
        const auto n = static_cast<std::int64_t>(obj.type() == T::list ? obj.items().size()
                                                                        : obj.text().size());
        std::int64_t i = key.as_int();
        if (i < 0) i += n;
        if (i < 0 || i >= n) return Value::undefined(what);
        if (obj.type() == T::list) return obj.items()[static_cast<std::size_t>(i)];
        return Value::string(std::string(1, obj.text()[static_cast<std::size_t>(i)]));
      }
      default: return Value::undefined(what);
    }
  }

  // Python arithmetic on ints (64-bit, overflow checked) and floats.
  Value binary(const std::string& op, const Value& a, const Value& b, std::uint32_t line) {
    if (op == "~") {
      std::string s = str_of(a, line);
      std::string t = str_of(b, line);
      check_string_size(s.size() + t.size(), line);
      return Value::string(s + t);
    }
    if (a.is_undefined()) undefined_error(a, line);
    if (b.is_undefined()) undefined_error(b, line);
    const bool ints = (a.type() == T::integer || a.type() == T::boolean) &&
                      (b.type() == T::integer || b.type() == T::boolean);
    if (a.is_number() && b.is_number()) {
      const double x = a.to_double(), y = b.to_double();
      if (op == "+" || op == "-" || op == "*") {
        if (ints) {
          std::int64_t r = 0;
          const bool over = op == "+"   ? __builtin_add_overflow(a.as_int(), b.as_int(), &r)
                            : op == "-" ? __builtin_sub_overflow(a.as_int(), b.as_int(), &r)
                                        : __builtin_mul_overflow(a.as_int(), b.as_int(), &r);
          if (over) fail(line, "integer overflow (beyond 64 bits)");
          return Value::integer(r);
        }
        return Value::number(op == "+" ? x + y : op == "-" ? x - y : x * y);
      }
      if (op == "/") {
        if (y == 0.0) fail(line, "division by zero");
        return Value::number(x / y);
      }
      if (op == "//" || op == "%") {
        if (y == 0.0) fail(line, op == "//" ? "integer division or modulo by zero" : "modulo by zero");
        if (ints) {
          const std::int64_t p = a.as_int(), q = b.as_int();
          if (p == std::numeric_limits<std::int64_t>::min() && q == -1) fail(line, "integer overflow");
          std::int64_t d = p / q, m = p % q;
          if (m != 0 && ((m < 0) != (q < 0))) {
            --d;
            m += q;
          }
          return Value::integer(op == "//" ? d : m);
        }
        double m = std::fmod(x, y);
        if (m != 0.0 && ((m < 0) != (y < 0))) m += y;
        if (op == "%") return Value::number(m);
        return Value::number(std::floor(x / y));
      }
      if (op == "**") {
        if (ints && b.as_int() >= 0) {
          std::int64_t r = 1, base = a.as_int();
          for (std::int64_t k = 0; k < b.as_int(); ++k) {
            if (__builtin_mul_overflow(r, base, &r)) fail(line, "integer overflow (beyond 64 bits)");
            if (r == 0 || r == 1) break;
            if (r == -1) {  // (-1) ** n: the sign of the parity
              r = (b.as_int() - k - 1) % 2 == 0 ? -1 : 1;
              break;
            }
          }
          return Value::integer(r);
        }
        if (x == 0.0 && y < 0) fail(line, "0.0 cannot be raised to a negative power");
        const double r = std::pow(x, y);
        if (std::isnan(r)) fail(line, "a negative number raised to a fractional power");
        return Value::number(r);
      }
    }
    if (op == "+" && a.type() == T::string && b.type() == T::string) {
      check_string_size(a.text().size() + b.text().size(), line);
      work(a.text().size() + b.text().size(), line);
      return Value::string(a.text() + b.text());
    }
    if (op == "+" && a.type() == T::list && b.type() == T::list) {
      check_list_size(a.items().size() + b.items().size(), line);
      List l = copy_items(a, line);
      List r = copy_items(b, line);
      l.insert(l.end(), std::make_move_iterator(r.begin()), std::make_move_iterator(r.end()));
      return Value::list(std::move(l));
    }
    if (op == "*" && (a.type() == T::string || a.type() == T::list) &&
        (b.type() == T::integer || b.type() == T::boolean)) {
      const std::int64_t n = std::max<std::int64_t>(0, b.as_int());
      const std::size_t unit = a.type() == T::string ? a.text().size() : a.items().size();
      // An empty string or list repeated any number of times is empty: no loop of n steps
      // that nothing else would count ('' * 10**9).
      if (unit == 0) return a.type() == T::string ? Value::string(std::string()) : Value::list(List{});
      const double total = static_cast<double>(n) * static_cast<double>(unit);
      if (a.type() == T::string) check_string_size(static_cast<std::uint64_t>(std::min(total, 1e18)), line);
      if (a.type() == T::list) {
        check_list_size(static_cast<std::uint64_t>(std::min(total, 1e18)), line);
        const double fp = static_cast<double>(n) * static_cast<double>(a.footprint());
        if (fp > static_cast<double>(limits_.max_value_bytes)) {
          limit(line, fmt::format("value limit: found a value of more than {} MiB (counted as printed), "
                                  "expected at most {} MiB",
                                  limits_.max_value_bytes >> 20, limits_.max_value_bytes >> 20));
        }
        allocate(static_cast<std::uint64_t>(fp), line);
      }
      work(static_cast<std::uint64_t>(std::min(total, 1e18)), line);
      if (a.type() == T::string) {
        std::string s;
        s.reserve(static_cast<std::size_t>(total));
        for (std::int64_t k = 0; k < n; ++k) s += a.text();
        return Value::string(std::move(s));
      }
      List l;
      for (std::int64_t k = 0; k < n; ++k) l.insert(l.end(), a.items().begin(), a.items().end());
      return Value::list(std::move(l));
    }
    if (op == "%" && a.type() == T::string) fail(line, "'%' string formatting is not supported");
    fail(line, fmt::format("unsupported operand types for {}: '{}' and '{}'", op, a.type_name(),
                           b.type_name()));
  }

  static int order(const Value& a, const Value& b, const std::string& op, std::uint32_t line) {
    if (a.is_number() && b.is_number()) {
      if (a.type() != T::number && b.type() != T::number) {
        return a.as_int() < b.as_int() ? -1 : a.as_int() > b.as_int() ? 1 : 0;
      }
      const double x = a.to_double(), y = b.to_double();
      if (std::isnan(x) || std::isnan(y)) return 2;  // every ordering is false
      return x < y ? -1 : x > y ? 1 : 0;
    }
    if (a.type() == T::string && b.type() == T::string) {
      const int c = a.text().compare(b.text());
      return c < 0 ? -1 : c > 0 ? 1 : 0;
    }
    if (a.type() == T::list && b.type() == T::list) {
      const List& x = a.items();
      const List& y = b.items();
      for (std::size_t i = 0; i < std::min(x.size(), y.size()); ++i) {
        if (!(x[i] == y[i])) return order(x[i], y[i], op, line);
      }
      return x.size() < y.size() ? -1 : x.size() > y.size() ? 1 : 0;
    }
    if (a.is_undefined()) undefined_error(a, line);
    if (b.is_undefined()) undefined_error(b, line);
    fail(line, fmt::format("'{}' not supported between '{}' and '{}'", op, a.type_name(),
                           b.type_name()));
  }

  static bool contains(const Value& container, const Value& x, std::uint32_t line) {
    switch (container.type()) {
      case T::string:
        if (x.type() != T::string) fail(line, "'in <string>' requires a string on the left");
        return container.text().find(x.text()) != std::string::npos;
      case T::list:
        return std::any_of(container.items().begin(), container.items().end(),
                           [&](const Value& v) { return v == x; });
      case T::dict: return x.type() == T::string && container.entries().find(x.text()) != nullptr;
      case T::undefined: return false;  // Jinja's Undefined iterates as empty
      default: fail(line, fmt::format("argument of type '{}' is not iterable", container.type_name()));
    }
  }

  static bool compare(const std::string& op, const Value& a, const Value& b, std::uint32_t line) {
    if (op == "==") return a == b;
    if (op == "!=") return !(a == b);
    if (op == "in") return contains(b, a, line);
    if (op == "notin") return !contains(b, a, line);
    const int c = order(a, b, op, line);
    if (c == 2) return false;
    if (op == "<") return c < 0;
    if (op == "<=") return c <= 0;
    if (op == ">") return c > 0;
    return c >= 0;  // ">="
  }

  /// Positional and keyword arguments bound to the parameter names `names`.
  std::vector<std::optional<Value>> bind(const Expr& e, std::size_t first,
                                         std::initializer_list<std::string_view> names,
                                         const std::string& what) {
    std::vector<std::optional<Value>> out(names.size());
    const std::size_t positional = e.args.size() - first;
    if (positional > names.size()) {
      fail(e.line, fmt::format("{} takes at most {} arguments, {} given", what, names.size(), positional));
    }
    for (std::size_t i = 0; i < positional; ++i) out[i] = eval(*e.args[first + i]);
    for (const auto& [key, expr] : e.kwargs) {
      const auto it = std::find(names.begin(), names.end(), key);
      if (it == names.end()) fail(e.line, fmt::format("{} has no argument '{}'", what, key));
      out[static_cast<std::size_t>(it - names.begin())] = eval(*expr);
    }
    return out;
  }

  Value filter(const Expr& e) {
    const std::string& f = e.text;
    if (f == "default" || f == "d") {
      // default(value, default_value='', boolean=False) (jinja2/filters.py do_default)
      Value v = eval(*e.args[0]);
      auto a = bind(e, 1, {"default_value", "boolean"}, "default");
      const bool boolean = a[1] && a[1]->truthy();
      if (v.is_undefined() || (boolean && !v.truthy())) return a[0] ? *a[0] : Value::string("");
      return v;
    }
    const Value v = eval(*e.args[0]);
    if (f == "float") {
      // do_float: float(value), else the default as given. float() of an undefined value
      // raises (Jinja 3.1's Undefined.__float__), so params.MISSING|float is an error.
      auto a = bind(e, 1, {"default"}, "float");
      if (v.is_undefined()) undefined_error(v, e.line);
      double d = 0.0;
      if (v.is_number()) return Value::number(v.to_double());
      if (v.type() == T::string) work(v.text().size(), e.line);
      if (v.type() == T::string && parse_python_float(v.text(), d)) return Value::number(d);
      return a[0] ? *a[0] : Value::number(0.0);
    }
    if (f == "int") {
      // do_int: int(value), else int(float(value)), else the default (0).
      auto a = bind(e, 1, {"default", "base"}, "int");
      if (a[1] && !(a[1]->type() == T::integer && a[1]->as_int() == 10)) {
        fail(e.line, "int(base=...) other than 10 is not supported");
      }
      const Value fallback = a[0] ? *a[0] : Value::integer(0);
      if (v.is_undefined()) undefined_error(v, e.line);
      if (v.type() == T::integer || v.type() == T::boolean) return Value::integer(v.as_int());
      double d = 0.0;
      if (v.type() == T::string) {
        work(v.text().size(), e.line);
        std::int64_t i = 0;
        if (parse_python_int(v.text(), i)) return Value::integer(i);
        if (!parse_python_float(v.text(), d)) return fallback;
      } else if (v.type() == T::number) {
        d = v.to_double();
      } else {
        return fallback;
      }
      if (!std::isfinite(d) || std::fabs(d) >= 9.2e18) return fallback;
      return Value::integer(static_cast<std::int64_t>(std::trunc(d)));
    }
    if (f == "round") {
      // do_round(value, precision=0, method='common'): always a float; 'common' is Python's
      // round(), which rounds exact halves to even.
      auto a = bind(e, 1, {"precision", "method"}, "round");
      const std::int64_t p = a[0] ? a[0]->as_int() : 0;
      const std::string method = a[1] ? a[1]->str() : "common";
      if (!v.is_number()) fail(e.line, fmt::format("round of '{}'", v.is_undefined() ? v.text() : std::string(v.type_name())));
      if (p < 0 || p > 15) fail(e.line, "round precision must be in [0, 15]");
      const double x = v.to_double(), scale = std::pow(10.0, static_cast<double>(p));
      if (method == "floor") return Value::number(std::floor(x * scale) / scale);
      if (method == "ceil") return Value::number(std::ceil(x * scale) / scale);
      if (method != "common") fail(e.line, "round method must be common, ceil or floor");
      if (v.type() == T::integer || v.type() == T::boolean) return Value::integer(v.as_int());
      if (p == 0) return Value::number(std::nearbyint(x));
      // Correctly rounded decimal, as Python's round(x, p).
      char buf[512];
      std::snprintf(buf, sizeof buf, "%.*f", static_cast<int>(p), x);
      return Value::number(std::strtod(buf, nullptr));
    }
    if (f == "abs") {
      bind(e, 1, {}, "abs");
      if (v.type() == T::integer || v.type() == T::boolean) {
        if (v.as_int() == std::numeric_limits<std::int64_t>::min()) fail(e.line, "integer overflow");
        return Value::integer(std::abs(v.as_int()));
      }
      if (v.type() == T::number) return Value::number(std::fabs(v.to_double()));
      if (v.is_undefined()) undefined_error(v, e.line);
      fail(e.line, fmt::format("bad operand type for abs(): '{}'", v.type_name()));
    }
    if (f == "lower" || f == "upper" || f == "string" || f == "trim" || f == "capitalize") {
      bind(e, 1, {}, f);
      std::string s = str_of(v, e.line);
      if (f == "trim") return Value::string(std::string(trim_ws(s)));
      if (f == "capitalize") {
        for (std::size_t i = 0; i < s.size(); ++i) {
          s[i] = static_cast<char>(i == 0 ? std::toupper(static_cast<unsigned char>(s[i]))
                                           : std::tolower(static_cast<unsigned char>(s[i])));
        }
        return Value::string(std::move(s));
      }
      if (f != "string") {
        for (char& c : s) {
          c = static_cast<char>(f == "lower" ? std::tolower(static_cast<unsigned char>(c))
                                             : std::toupper(static_cast<unsigned char>(c)));
        }
      }
      return Value::string(std::move(s));
    }
    if (f == "length" || f == "count") {
      bind(e, 1, {}, f);
      switch (v.type()) {
        case T::undefined: return Value::integer(0);
        case T::string: return Value::integer(static_cast<std::int64_t>(v.text().size()));
        case T::list: return Value::integer(static_cast<std::int64_t>(v.items().size()));
        case T::dict: return Value::integer(static_cast<std::int64_t>(v.entries().items.size()));
        default: fail(e.line, fmt::format("object of type '{}' has no len()", v.type_name()));
      }
    }
    if (f == "join") {
      auto a = bind(e, 1, {"d"}, "join");
      const std::string sep = a[0] ? str_of(*a[0], e.line) : "";
      std::string s;
      const List l = copy_items(v, e.line);
      for (std::size_t i = 0; i < l.size(); ++i) {
        if (i != 0) s += sep;
        s += str_of(l[i], e.line);
        check_string_size(s.size(), e.line);  // before the next piece: joins of huge pieces stop early
        work(sep.size(), e.line);
      }
      allocate(s.size(), e.line);
      return Value::string(std::move(s));
    }
    if (f == "list") {
      bind(e, 1, {}, f);
      return Value::list(copy_items(v, e.line));
    }
    if (f == "first" || f == "last") {
      bind(e, 1, {}, f);
      const List l = copy_items(v, e.line);
      if (l.empty()) return Value::undefined(f + " of an empty sequence");
      return f == "first" ? l.front() : l.back();
    }
    if (f == "min" || f == "max") {
      bind(e, 1, {}, f);
      const List l = copy_items(v, e.line);
      work(v.footprint(), e.line);
      if (l.empty()) return Value::undefined(f + " of an empty sequence");
      Value best = l.front();
      for (const Value& x : l) {
        const int c = order(x, best, f == "min" ? "<" : ">", e.line);
        if ((f == "min" && c == -1) || (f == "max" && c == 1)) best = x;
      }
      return best;
    }
    if (f == "sum") {
      bind(e, 1, {}, f);
      Value total = Value::integer(0);
      for (const Value& x : copy_items(v, e.line)) total = binary("+", total, x, e.line);
      return total;
    }
    if (f == "replace") {
      auto a = bind(e, 1, {"old", "new"}, "replace");
      if (!a[0] || !a[1]) fail(e.line, "replace needs old and new");
      return Value::string(replace_all(str_of(v, e.line), str_of(*a[0], e.line), str_of(*a[1], e.line), e.line));
    }
    fail(e.line, fmt::format("filter '{}' is not supported", f));
  }

  /// Python's str.replace(old, new): every occurrence, left to right, not overlapping; an
  /// empty `from` puts `to` before every character and at the end. The result's size is
  /// known (and bounded) before it is built; built in one linear pass.
  std::string replace_all(const std::string& s, const std::string& from, const std::string& to,
                          std::uint32_t line) {
    work(s.size() * std::max<std::uint64_t>(1, from.size()) + to.size(), line);
    std::uint64_t count = 0;
    if (from.empty()) {
      count = s.size() + 1;
    } else {
      for (std::size_t pos = 0; (pos = s.find(from, pos)) != std::string::npos; pos += from.size()) ++count;
    }
    const double size = static_cast<double>(s.size()) +
                        static_cast<double>(count) * (static_cast<double>(to.size()) - static_cast<double>(from.size()));
    check_string_size(static_cast<std::uint64_t>(std::min(size, 1e18)), line);
    work(static_cast<std::uint64_t>(size), line);
    allocate(static_cast<std::uint64_t>(size), line);
    std::string out;
    out.reserve(static_cast<std::size_t>(size));
    if (from.empty()) {
      for (char c : s) {
        out += to;
        out += c;
      }
      out += to;
      return out;
    }
    std::size_t at = 0;
    for (std::size_t pos = 0; (pos = s.find(from, at)) != std::string::npos; at = pos + from.size()) {
      out.append(s, at, pos - at);
      out += to;
    }
    out.append(s, at, std::string::npos);
    return out;
  }

  static List sequence(const Value& v, std::uint32_t line) {
    switch (v.type()) {
      case T::undefined: return {};
      case T::list: return v.items();
      case T::dict: {
        List l;
        for (const auto& [k, x] : v.entries().items) l.push_back(Value::string(k));
        return l;
      }
      case T::string: {
        List l;
        for (char c : v.text()) l.push_back(Value::string(std::string(1, c)));
        return l;
      }
      default: fail(line, fmt::format("'{}' object is not iterable", v.type_name()));
    }
  }

  bool test(const Expr& e) {
    const std::string& t = e.text;
    const Value v = eval(*e.args[0]);
    if (t == "defined") return !v.is_undefined();
    if (t == "undefined") return v.is_undefined();
    if (t == "none") return v.type() == T::none;
    if (t == "number") return v.is_number();
    if (t == "integer") return v.type() == T::integer;
    if (t == "float") return v.type() == T::number;
    if (t == "string") return v.type() == T::string;
    if (t == "boolean") return v.type() == T::boolean;
    if (t == "true") return v.type() == T::boolean && v.as_bool();
    if (t == "false") return v.type() == T::boolean && !v.as_bool();
    if (t == "mapping") return v.type() == T::dict;
    if (t == "sequence" || t == "iterable") {
      return v.type() == T::list || v.type() == T::string || v.type() == T::dict;
    }
    if (t == "even" || t == "odd" || t == "divisibleby") {
      std::int64_t n = 2;
      if (t == "divisibleby") {
        auto a = bind(e, 1, {"num"}, "divisibleby");
        if (!a[0] || !a[0]->is_number() || a[0]->as_int() == 0) fail(e.line, "divisibleby needs a non-zero integer");
        n = a[0]->as_int();
      }
      if (v.is_undefined()) undefined_error(v, e.line);
      if (!v.is_number()) fail(e.line, fmt::format("'{}' is not a number", v.type_name()));
      const std::int64_t i = v.type() == T::number ? static_cast<std::int64_t>(v.to_double()) : v.as_int();
      if (t == "odd") return i % 2 != 0;
      return i % n == 0;
    }
    fail(e.line, fmt::format("test '{}' is not supported", t));
  }

  Value call(const Expr& e) {
    const Value fn = eval(*e.args[0]);
    if (fn.type() != T::function) {
      if (fn.is_undefined()) fail(e.line, fmt::format("'{}' is undefined (not a function amctl knows)", fn.text()));
      fail(e.line, fmt::format("'{}' object is not callable", fn.type_name()));
    }
    const std::string& name = fn.text();
    if (const Value* self = fn.self()) return method(*self, name, e);
    if (name == "range") {
      auto a = bind(e, 1, {"start", "stop", "step"}, "range");
      std::int64_t start = 0, stop = 0, step = 1;
      for (const auto& x : a) {
        if (x && x->type() != T::integer && x->type() != T::boolean) {
          fail(e.line, fmt::format("range() needs integers, got '{}'", x->type_name()));
        }
      }
      if (!a[0]) fail(e.line, "range() needs at least one argument");
      if (a[1]) {
        start = a[0]->as_int();
        stop = a[1]->as_int();
        if (a[2]) step = a[2]->as_int();
      } else {
        stop = a[0]->as_int();
      }
      if (step == 0) fail(e.line, "range() step must not be zero");
      // Exact in 128 bits: a range near the 64-bit limits neither overflows nor loops.
      const __int128 span = static_cast<__int128>(stop) - start;
      const __int128 st = step;
      __int128 count = 0;
      if (step > 0 && span > 0) count = (span + st - 1) / st;
      if (step < 0 && span < 0) count = (-span - st - 1) / -st;
      if (count > static_cast<__int128>(limits_.max_range_length)) {
        limit(e.line, fmt::format("range limit: found range() of {:.0f} values, expected at most {}",
                                  static_cast<double>(count), limits_.max_range_length));
      }
      const auto n = static_cast<std::size_t>(count);
      work(n, e.line);
      allocate(n * sizeof(Value), e.line);
      List l;
      l.reserve(n);
      for (std::size_t k = 0; k < n; ++k) {
        l.push_back(Value::integer(static_cast<std::int64_t>(start + static_cast<__int128>(k) * st)));
      }
      return Value::list(std::move(l));
    }
    if (name == "namespace") {
      if (!e.args.empty() && e.args.size() > 1) fail(e.line, "namespace() takes keyword arguments only");
      Dict d;
      for (const auto& [k, x] : e.kwargs) d.set(k, eval(*x));
      return Value::dict(std::move(d));
    }
    if (name == "action_respond_info" || name == "action_call_remote_method") {
      for (std::size_t i = 1; i < e.args.size(); ++i) (void)eval(*e.args[i]);
      return Value::string("");
    }
    if (name == "action_raise_error" || name == "action_emergency_stop") {
      std::string msg = e.args.size() > 1 ? str_of(eval(*e.args[1]), e.line) : name;
      if (msg.size() > 200) msg = msg.substr(0, 200) + "...";
      fail(e.line, fmt::format("{}(\"{}\"): Klipper stops the print here", name, msg));
    }
    fail(e.line, fmt::format("function '{}' is not supported", name));
  }

  Value method(const Value& self, const std::string& name, const Expr& e) {
    if (self.type() == T::dict) {
      if (name == "get") {
        auto a = bind(e, 1, {"key", "default"}, "get");
        if (!a[0]) fail(e.line, "get() needs a key");
        if (a[0]->type() == T::string) {
          if (const Value* v = self.entries().find(a[0]->text())) return *v;
        }
        return a[1] ? *a[1] : Value::none();
      }
      bind(e, 1, {}, name);
      work(self.footprint(), e.line);
      allocate(self.entries().items.size() * 3 * sizeof(Value) + self.footprint(), e.line);
      List l;
      for (const auto& [k, v] : self.entries().items) {
        if (name == "keys") l.push_back(Value::string(k));
        else if (name == "values") l.push_back(v);
        else l.push_back(Value::list({Value::string(k), v}));
      }
      return Value::list(std::move(l));
    }
    if (self.type() == T::number && name == "is_integer") {
      return Value::boolean(std::trunc(self.to_double()) == self.to_double());
    }
    const std::string& s = self.text();
    if (name == "lower" || name == "upper" || name == "capitalize" || name == "title") {
      bind(e, 1, {}, name);
      work(s.size(), e.line);
      std::string r = s;
      bool start = true;
      for (std::size_t i = 0; i < r.size(); ++i) {
        const auto c = static_cast<unsigned char>(r[i]);
        const bool up = name == "upper" || ((name == "capitalize" && i == 0) || (name == "title" && start));
        r[i] = static_cast<char>(up ? std::toupper(c) : std::tolower(c));
        start = !std::isalpha(c);
      }
      return Value::string(std::move(r));
    }
    if (name == "isdigit") {
      return Value::boolean(!s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }));
    }
    if (name == "strip" || name == "lstrip" || name == "rstrip") {
      auto a = bind(e, 1, {"chars"}, name);
      const std::string chars = a[0] ? str_of(*a[0], e.line) : std::string(" \t\n\r\f\v");
      work(s.size() * (1 + chars.size()), e.line);
      std::size_t b = 0, en = s.size();
      if (name != "rstrip") b = std::min(s.find_first_not_of(chars), s.size());
      if (name != "lstrip") en = s.find_last_not_of(chars) == std::string::npos ? b : s.find_last_not_of(chars) + 1;
      return Value::string(en > b ? s.substr(b, en - b) : std::string());
    }
    if (name == "startswith" || name == "endswith") {
      auto a = bind(e, 1, {"prefix"}, name);
      if (!a[0] || a[0]->type() != T::string) fail(e.line, fmt::format("{}() needs a string", name));
      const std::string& p = a[0]->text();
      const bool ok = p.size() <= s.size() &&
                      (name == "startswith" ? s.compare(0, p.size(), p) == 0
                                            : s.compare(s.size() - p.size(), p.size(), p) == 0);
      return Value::boolean(ok);
    }
    if (name == "replace") {
      auto a = bind(e, 1, {"old", "new"}, name);
      if (!a[0] || !a[1]) fail(e.line, "replace() needs old and new");
      return Value::string(replace_all(s, str_of(*a[0], e.line), str_of(*a[1], e.line), e.line));
    }
    if (name == "split") {
      auto a = bind(e, 1, {"sep", "maxsplit"}, name);
      const std::int64_t maxsplit = a[1] && a[1]->is_number() ? a[1]->as_int() : -1;
      List l;
      auto add = [&](std::string piece) {
        check_list_size(l.size() + 1, e.line);
        allocate(sizeof(Value) + piece.size(), e.line);
        l.push_back(Value::string(std::move(piece)));
      };
      work(s.size(), e.line);
      if (!a[0] || a[0]->type() == T::none) {
        std::size_t i = 0;
        while (i < s.size()) {
          while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
          const std::size_t b = i;
          while (i < s.size() && !std::isspace(static_cast<unsigned char>(s[i]))) ++i;
          if (i > b) add(s.substr(b, i - b));
        }
      } else {
        const std::string sep = str_of(*a[0], e.line);
        if (sep.empty()) fail(e.line, "empty separator");
        work(s.size() * sep.size(), e.line);
        std::size_t b = 0, at = 0;
        std::int64_t splits = 0;
        while ((maxsplit < 0 || splits++ < maxsplit) && (at = s.find(sep, b)) != std::string::npos) {
          add(s.substr(b, at - b));
          b = at + sep.size();
        }
        add(s.substr(b));
      }
      return Value::list(std::move(l));
    }
    fail(e.line, fmt::format("method '{}' is not supported", name));
  }

  const Dict& globals_;
  const RenderLimits& limits_;
  Dict top_;                  // names set at the top level
  std::vector<Dict> frames_;  // loop scopes
  std::uint64_t iterations_ = 0;
  std::uint64_t work_ = 0;       // RenderLimits::max_work
  std::uint64_t allocated_ = 0;  // RenderLimits::max_allocated_bytes
  std::string out_;

 public:
  /// The top-level scope sits above the globals: assignments there shadow them.
  void begin() { frames_.push_back(std::move(top_)); }
};

/// literal_eval: only literals, lists, tuples, dicts and unary minus on numbers.
Value literal(const Expr& e) {
  switch (e.kind) {
    case Expr::Kind::literal: return e.value;
    case Expr::Kind::name:
      throw TemplateError(e.line, fmt::format("'{}' is not a literal (a string needs quotes)", e.text));
    case Expr::Kind::unary: {
      if (e.text == "not") break;
      const Value v = literal(*e.args[0]);
      if (v.type() == T::integer) return Value::integer(e.text == "-" ? -v.as_int() : v.as_int());
      if (v.type() == T::number) return Value::number(e.text == "-" ? -v.to_double() : v.to_double());
      break;
    }
    case Expr::Kind::list: {
      List l;
      for (const auto& a : e.args) l.push_back(literal(*a));
      return Value::list(std::move(l), false, e.tuple);
    }
    case Expr::Kind::dict: {
      Dict d;
      for (std::size_t i = 0; i < e.args.size(); ++i) {
        const Value k = literal(*e.keys[i]);
        if (k.type() != T::string) throw TemplateError(e.line, "dict keys must be strings here");
        d.set(k.text(), literal(*e.args[i]));
      }
      return Value::dict(std::move(d));
    }
    default: break;
  }
  throw TemplateError(e.line, "not a literal (numbers, strings, True/False/None, lists, dicts)");
}

}  // namespace
}  // namespace detail

Template Template::compile(std::string_view text) {
  if (text.size() > kMaxTemplateBytes) {
    throw LimitError(1, fmt::format("template size limit: found a template of {} bytes, expected at most {}",
                                    text.size(), kMaxTemplateBytes));
  }
  // Jinja drops one newline at the end of the source (keep_trailing_newline = False).
  if (!text.empty() && text.back() == '\n') text.remove_suffix(1);
  Template t;
  t.body_ = detail::parse_template(text);
  return t;
}

std::string Template::render(const Dict& globals, const RenderLimits& limits) const {
  detail::Renderer r(globals, limits);
  r.begin();
  r.run(body_->nodes);
  return std::move(r.output());
}

Value parse_literal(std::string_view text) {
  const std::string_view t = detail::trim_ws(text);
  // Python literals spelled the Python way only (Jinja's lowercase true/none are not).
  if (t == "true" || t == "false" || t == "none") {
    throw TemplateError(1, fmt::format("'{}' is not a Python literal (True, False, None)", t));
  }
  return detail::literal(*detail::parse_expression(t));
}

}  // namespace amctl::macro
