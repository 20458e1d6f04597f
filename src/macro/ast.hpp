#pragma once
// The syntax tree of a template (internal to the macro module): expressions and statements,
// each with its 1-based template line for messages.
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "amctl/macro/value.hpp"

namespace amctl::macro::detail {

struct Expr;
using ExprPtr = std::unique_ptr<Expr>;

struct Expr {
  enum class Kind : std::uint8_t {
    literal,  ///< value
    name,     ///< text
    attr,     ///< args[0].text
    item,     ///< args[0][args[1]]
    call,     ///< args[0](args[1..], kwargs)
    filter,   ///< args[0] | text(args[1..], kwargs)
    test,     ///< args[0] is [not] text(args[1..])
    unary,    ///< text in {"-", "+", "not"}
    binary,   ///< args[0] text args[1]; text in + - * / // % ** ~
    compare,  ///< args[0] ops[0] args[1] ops[1] args[2] ... (chained)
    logic,    ///< text in {"and", "or"}
    cond,     ///< args[1] if args[0] else args[2] (args[2] absent: undefined)
    list,     ///< [args...] or a tuple
    dict      ///< keys[i]: args[i]
  };
  Kind kind = Kind::literal;
  std::uint32_t line = 0;
  /// Nodes on the longest path down from here, itself included (bounded by kMaxNesting, so
  /// evaluating and destroying the tree never recurse deeper).
  std::uint32_t depth = 1;
  Value value;
  std::string text;
  bool negated = false;  ///< `is not`
  bool tuple = false;    ///< list: written as a tuple
  std::vector<ExprPtr> args;
  std::vector<std::pair<std::string, ExprPtr>> kwargs;
  std::vector<std::string> ops;   ///< compare operators: == != < <= > >= in notin
  std::vector<ExprPtr> keys;      ///< dict keys
};

struct Node;
using NodeList = std::vector<Node>;

struct Node {
  enum class Kind : std::uint8_t { text, output, if_, for_, set };
  Kind kind = Kind::text;
  std::uint32_t line = 0;
  std::string text;                 ///< text
  ExprPtr expr;                     ///< output, for_ (iterable), set (value)
  std::vector<std::string> targets; ///< for_ / set names; set "ns.attr" as {"ns", "attr"} with attr_target
  bool attr_target = false;         ///< set ns.attr = ...
  /// if_: (condition, body) for if and each elif; else in else_body. for_: body in
  /// branches[0].second, loop else in else_body.
  std::vector<std::pair<ExprPtr, NodeList>> branches;
  NodeList else_body;
};

struct Body {
  NodeList nodes;
};

}  // namespace amctl::macro::detail
