#pragma once
// The values a Klipper macro template computes with: Jinja2's view of Python objects, reduced
// to what printer macros use (docs/macros.md, "Values"). A Value is a small immutable value
// type; lists and dicts share their elements (copying a Value never copies a list).
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

namespace amctl::macro {

class Value;
using List = std::vector<Value>;

/// A Python dict: insertion order kept, string keys (all macros use). Lookups are constant
/// time: beyond a few items a hash index of the keys is kept beside them (so a printer.cfg
/// with thousands of sections or macros costs linear time to read, not quadratic).
struct Dict {
  std::vector<std::pair<std::string, Value>> items;  ///< change only through set()
  [[nodiscard]] const Value* find(std::string_view key) const;
  /// Inserts or replaces.
  void set(std::string key, Value v);

 private:
  std::unordered_map<std::string, std::size_t> index_;  // key -> position, once items are many
};

class Value {
 public:
  enum class Type : std::uint8_t {
    undefined,  ///< Jinja's Undefined: renders as "", is false, fails in arithmetic
    none,       ///< Python None
    boolean,
    integer,    ///< Python int (64-bit here; overflow is an error)
    number,     ///< Python float
    string,
    list,       ///< list or tuple; a Klipper Coord is a list of 4 with .x .y .z .e
    dict,
    function    ///< a built-in callable (range, action_*) or a bound method ("lower" of a str)
  };

  Value() = default;  ///< undefined
  static Value undefined(std::string what);  ///< `what`: the expression, for messages
  static Value none();
  static Value boolean(bool b);
  static Value integer(std::int64_t i);
  static Value number(double d);
  static Value string(std::string s);
  /// A list; `tuple`: a Python tuple (prints as "(1, 2)", never equal to a list); `coord`: a
  /// Klipper Coord, a tuple with .x .y .z .e.
  static Value list(List items, bool coord = false, bool tuple = false);
  static Value dict(Dict d);
  static Value function(std::string name, std::shared_ptr<const Value> self = nullptr);

  [[nodiscard]] Type type() const { return type_; }
  [[nodiscard]] bool is_undefined() const { return type_ == Type::undefined; }
  [[nodiscard]] bool is_number() const {  ///< bool, int or float (Python's numeric tower)
    return type_ == Type::boolean || type_ == Type::integer || type_ == Type::number;
  }
  [[nodiscard]] bool as_bool() const { return b_; }
  [[nodiscard]] std::int64_t as_int() const { return i_; }
  /// bool, int or float as a double.
  [[nodiscard]] double to_double() const;
  /// The string of a string, the name of a function, the expression of an undefined.
  [[nodiscard]] const std::string& text() const { return s_; }
  [[nodiscard]] const List& items() const;
  [[nodiscard]] const Dict& entries() const;
  [[nodiscard]] bool is_coord() const { return coord_; }
  [[nodiscard]] bool is_tuple() const { return tuple_; }
  /// Nesting of lists and dicts (0 for a scalar): the evaluator bounds it, so printing,
  /// comparing and destroying a value never recurse deeply.
  [[nodiscard]] std::uint32_t depth() const { return depth_; }
  /// Size as it would print: string bytes plus 16 per value, lists and dicts summed over
  /// their items (an item shared by several lists counted each time), saturating. The
  /// evaluator bounds it (RenderLimits::max_value_bytes), so printing, comparing and copying
  /// a value costs at most that much.
  [[nodiscard]] std::uint64_t footprint() const { return footprint_; }
  [[nodiscard]] const Value* self() const { return self_.get(); }

  /// Python truth value (undefined is false).
  [[nodiscard]] bool truthy() const;
  /// Python str() (Jinja's output): undefined -> "", None -> "None", True -> "True",
  /// 200.0 -> "200.0", 1e-05 -> "1e-05", lists and dicts as Python's repr.
  [[nodiscard]] std::string str() const;
  /// Python repr(): strings quoted, otherwise str().
  [[nodiscard]] std::string repr() const;
  /// Python ==.
  friend bool operator==(const Value& a, const Value& b);
  /// Python's type name ("int", "str", ...), for messages.
  [[nodiscard]] std::string_view type_name() const;

 private:
  Type type_ = Type::undefined;
  bool b_ = false;
  bool coord_ = false;
  bool tuple_ = false;
  std::uint32_t depth_ = 0;
  std::uint64_t footprint_ = 16;
  std::int64_t i_ = 0;
  double d_ = 0.0;
  std::string s_;
  std::shared_ptr<const List> list_;
  std::shared_ptr<const Dict> dict_;
  std::shared_ptr<const Value> self_;
};

/// Python's repr of a float (shortest round-trip digits; positional for 1e-4 <= |x| < 1e16,
/// else "1e+16" style; "inf", "nan").
std::string python_float_repr(double x);

}  // namespace amctl::macro
