// Template text -> syntax tree. The template is cut into text, `{ expression }`,
// `{% statement %}` and `{# comment #}` pieces (Klipper's delimiters; `{%-` and `-%}` strip the
// whitespace next to them, as Jinja does); the pieces are tokenized and parsed by recursive
// descent with Jinja's operator precedence (jinja2/parser.py): conditional expression, or,
// and, not, comparisons (chained, `in`, `not in`), `~`, + -, * / // %, **, unary - +, then
// postfix `.attr`, `[item]`, `(call)`, `|filter` and `is test`.
#include <charconv>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

#include "amctl/macro/template.hpp"
#include "ast.hpp"

namespace amctl::macro {
namespace detail {
namespace {

constexpr int kMaxDepth = static_cast<int>(kMaxNesting);  // nesting of expressions and statements

[[noreturn]] void nesting_error(std::uint32_t line, const char* what) {
  throw LimitError(line, fmt::format("nesting limit: found {} nested more than {} deep (a chain such as "
                                     "a|f|f, a.b.c or 1+1+1 counts one level per link), expected at most {}",
                                     what, kMaxNesting, kMaxNesting));
}

/// Sets e's depth from its children (whose depths are set) and enforces kMaxNesting: every
/// node goes through here once its children are attached.
ExprPtr seal(ExprPtr e) {
  std::uint32_t d = 0;
  for (const auto& a : e->args) {
    if (a) d = std::max(d, a->depth);
  }
  for (const auto& kv : e->kwargs) d = std::max(d, kv.second->depth);
  for (const auto& k : e->keys) d = std::max(d, k->depth);
  e->depth = d + 1;
  if (e->depth > kMaxNesting) nesting_error(e->line, "expression");
  return e;
}

struct Token {
  enum class Kind : std::uint8_t { name, integer, number, string, op, end };
  Kind kind = Kind::end;
  std::string text;
  Value value;
  std::uint32_t line = 0;
};

bool is_name_start(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
}
bool is_digit(char c) { return c >= '0' && c <= '9'; }

/// Tokenizes an expression or statement from `pos` until its closing delimiter at bracket depth
/// 0: "}" for an expression, "%}" (or "-%}") for a statement. Sets `strip_after` for "-%}".
std::vector<Token> tokenize(std::string_view s, std::size_t& pos, std::uint32_t& line,
                            bool statement, bool& strip_after, std::uint32_t open_line) {
  std::vector<Token> out;
  int depth = 0;
  strip_after = false;
  while (true) {
    if (pos >= s.size()) {
      throw TemplateError(open_line, statement ? "'{%' is never closed by '%}'"
                                               : "'{' is never closed by '}'");
    }
    const char c = s[pos];
    if (c == '\n') {
      ++line;
      ++pos;
      continue;
    }
    if (c == ' ' || c == '\t' || c == '\r') {
      ++pos;
      continue;
    }
    if (depth == 0) {
      if (statement) {
        if (s.substr(pos, 3) == "-%}") {
          strip_after = true;
          pos += 3;
          break;
        }
        if (s.substr(pos, 2) == "%}") {
          pos += 2;
          break;
        }
      } else if (c == '}') {
        ++pos;
        break;
      } else if (c == '-' && pos + 1 < s.size() && s[pos + 1] == '}') {
        strip_after = true;  // "-}": Jinja's whitespace control, as for "-%}"
        pos += 2;
        break;
      }
    }
    Token t;
    t.line = line;
    if (is_name_start(c)) {
      const std::size_t b = pos;
      while (pos < s.size() && (is_name_start(s[pos]) || is_digit(s[pos]))) ++pos;
      t.kind = Token::Kind::name;
      t.text = std::string(s.substr(b, pos - b));
    } else if (is_digit(c) || (c == '.' && pos + 1 < s.size() && is_digit(s[pos + 1]))) {
      const std::size_t b = pos;
      bool is_float = false;
      while (pos < s.size() && (is_digit(s[pos]) || s[pos] == '_')) ++pos;
      if (pos < s.size() && s[pos] == '.' && pos + 1 < s.size() && is_digit(s[pos + 1])) {
        is_float = true;
        ++pos;
        while (pos < s.size() && (is_digit(s[pos]) || s[pos] == '_')) ++pos;
      }
      if (pos < s.size() && (s[pos] == 'e' || s[pos] == 'E')) {
        std::size_t q = pos + 1;
        if (q < s.size() && (s[q] == '+' || s[q] == '-')) ++q;
        if (q < s.size() && is_digit(s[q])) {
          is_float = true;
          pos = q;
          while (pos < s.size() && is_digit(s[pos])) ++pos;
        }
      }
      std::string digits;
      for (char d : s.substr(b, pos - b)) {
        if (d != '_') digits += d;
      }
      if (is_float) {
        t.kind = Token::Kind::number;
        t.value = Value::number(std::strtod(digits.c_str(), nullptr));
      } else {
        std::int64_t v = 0;
        const auto r = std::from_chars(digits.data(), digits.data() + digits.size(), v);
        if (r.ec != std::errc()) {
          throw TemplateError(line, fmt::format("integer '{}' is too large", digits));
        }
        t.kind = Token::Kind::integer;
        t.value = Value::integer(v);
      }
      t.text = digits;
    } else if (c == '\'' || c == '"') {
      const char q = c;
      std::string text;
      ++pos;
      while (true) {
        if (pos >= s.size() || s[pos] == '\n') {
          throw TemplateError(t.line, "string literal is never closed");
        }
        char d = s[pos++];
        if (d == q) break;
        if (d == '\\' && pos < s.size()) {
          const char e = s[pos++];
          switch (e) {
            case 'n': d = '\n'; break;
            case 't': d = '\t'; break;
            case 'r': d = '\r'; break;
            case '\\': d = '\\'; break;
            case '\'': d = '\''; break;
            case '"': d = '"'; break;
            case 'x': {  // \xNN
              int v = 0;
              const auto r = pos + 2 <= s.size()
                                 ? std::from_chars(s.data() + pos, s.data() + pos + 2, v, 16)
                                 : std::from_chars_result{s.data() + pos, std::errc::invalid_argument};
              if (r.ec != std::errc() || r.ptr != s.data() + pos + 2) {
                throw TemplateError(line, "truncated \\xXX escape");
              }
              d = static_cast<char>(v);
              pos += 2;
              break;
            }
            default:
              text += '\\';
              d = e;
          }
        }
        text += d;
      }
      t.kind = Token::Kind::string;
      t.value = Value::string(text);
      t.text = std::move(text);
    } else {
      static constexpr std::string_view kOps[] = {"**", "//", "==", "!=", "<=", ">=", "+", "-",
                                                  "*",  "/",  "%",  "~",  "<",  ">",  "(", ")",
                                                  "[",  "]",  "{",  "}",  ",",  ":",  ".", "|",
                                                  "="};
      std::string_view op;
      for (std::string_view o : kOps) {
        if (s.substr(pos, o.size()) == o) {
          op = o;
          break;
        }
      }
      if (op.empty()) {
        throw TemplateError(line, fmt::format("unexpected character '{}'", c));
      }
      if (op == "(" || op == "[" || op == "{") ++depth;
      if (op == ")" || op == "]" || op == "}") --depth;
      if (depth < 0) throw TemplateError(line, fmt::format("unbalanced '{}'", op));
      pos += op.size();
      t.kind = Token::Kind::op;
      t.text = std::string(op);
    }
    out.push_back(std::move(t));
  }
  Token end;
  end.line = line;
  out.push_back(std::move(end));
  return out;
}

/// Recursive-descent parser over the tokens of one expression or statement.
class ExprParser {
 public:
  ExprParser(std::vector<Token> toks) : t_(std::move(toks)) {}

  const Token& peek(std::size_t ahead = 0) const {
    return t_[std::min(i_ + ahead, t_.size() - 1)];
  }
  bool at_end() const { return peek().kind == Token::Kind::end; }
  bool is_op(std::string_view op, std::size_t ahead = 0) const {
    return peek(ahead).kind == Token::Kind::op && peek(ahead).text == op;
  }
  bool is_name(std::string_view n, std::size_t ahead = 0) const {
    return peek(ahead).kind == Token::Kind::name && peek(ahead).text == n;
  }
  Token next() { return t_[std::min(i_++, t_.size() - 1)]; }
  void expect_op(std::string_view op) {
    if (!is_op(op)) fail(fmt::format("expected '{}'", op));
    ++i_;
  }
  std::string expect_name() {
    if (peek().kind != Token::Kind::name) fail("expected a name");
    return next().text;
  }
  void expect_end() {
    if (!at_end()) fail("unexpected text");
  }
  [[noreturn]] void fail(const std::string& what) const {
    const Token& t = peek();
    const std::string found = t.kind == Token::Kind::end ? "the end" : fmt::format("'{}'", t.text);
    throw TemplateError(t.line, fmt::format("{}, found {}", what, found));
  }

  ExprPtr expression() {
    Guard g(*this);
    ExprPtr body = logic_or();
    if (is_name("if")) {
      const std::uint32_t line = next().line;
      ExprPtr c = make(Expr::Kind::cond, line);
      c->args.push_back(logic_or());  // condition
      c->args.push_back(std::move(body));
      if (is_name("else")) {
        next();
        c->args.push_back(expression());
      }
      return seal(std::move(c));
    }
    return body;
  }

  /// A comma-separated list of expressions (a tuple when more than one), as after `in` or `=`.
  ExprPtr tuple_or_expression() {
    ExprPtr first = expression();
    if (!is_op(",")) return first;
    ExprPtr l = make(Expr::Kind::list, first->line);
    l->tuple = true;
    l->args.push_back(std::move(first));
    while (is_op(",")) {
      next();
      if (at_end() || is_op(")")) break;  // (1,) and a trailing comma
      l->args.push_back(expression());
    }
    return seal(std::move(l));
  }

 private:
  struct Guard {
    explicit Guard(ExprParser& p) : p_(p) {
      if (++p_.depth_ > kMaxDepth) nesting_error(p_.peek().line, "expression");
    }
    ~Guard() { --p_.depth_; }
    ExprParser& p_;
  };

  static ExprPtr make(Expr::Kind k, std::uint32_t line) {
    auto e = std::make_unique<Expr>();
    e->kind = k;
    e->line = line;
    return e;
  }

  ExprPtr logic_or() {
    ExprPtr l = logic_and();
    while (is_name("or")) {
      ExprPtr e = make(Expr::Kind::logic, next().line);
      e->text = "or";
      e->args.push_back(std::move(l));
      e->args.push_back(logic_and());
      l = seal(std::move(e));
    }
    return l;
  }
  ExprPtr logic_and() {
    ExprPtr l = logic_not();
    while (is_name("and")) {
      ExprPtr e = make(Expr::Kind::logic, next().line);
      e->text = "and";
      e->args.push_back(std::move(l));
      e->args.push_back(logic_not());
      l = seal(std::move(e));
    }
    return l;
  }
  ExprPtr logic_not() {
    if (is_name("not")) {
      Guard g(*this);
      ExprPtr e = make(Expr::Kind::unary, next().line);
      e->text = "not";
      e->args.push_back(logic_not());
      return seal(std::move(e));
    }
    return compare();
  }
  ExprPtr compare() {
    ExprPtr first = concat();
    ExprPtr c;
    while (true) {
      std::string op;
      if (peek().kind == Token::Kind::op &&
          (peek().text == "==" || peek().text == "!=" || peek().text == "<" ||
           peek().text == "<=" || peek().text == ">" || peek().text == ">=")) {
        op = next().text;
      } else if (is_name("in")) {
        next();
        op = "in";
      } else if (is_name("not") && is_name("in", 1)) {
        next();
        next();
        op = "notin";
      } else {
        break;
      }
      if (!c) {
        c = make(Expr::Kind::compare, first->line);
        c->args.push_back(std::move(first));
      }
      c->ops.push_back(op);
      c->args.push_back(concat());
    }
    return c ? seal(std::move(c)) : std::move(first);
  }
  ExprPtr binary_chain(ExprPtr (ExprParser::*sub)(), std::initializer_list<std::string_view> ops) {
    ExprPtr l = (this->*sub)();
    while (peek().kind == Token::Kind::op) {
      bool match = false;
      for (std::string_view o : ops) match = match || peek().text == o;
      if (!match) break;
      const Token t = next();
      ExprPtr e = make(Expr::Kind::binary, t.line);
      e->text = t.text;
      e->args.push_back(std::move(l));
      e->args.push_back((this->*sub)());
      l = seal(std::move(e));
    }
    return l;
  }
  ExprPtr concat() { return binary_chain(&ExprParser::math1, {"~"}); }
  ExprPtr math1() { return binary_chain(&ExprParser::math2, {"+", "-"}); }
  ExprPtr math2() { return binary_chain(&ExprParser::power, {"*", "/", "//", "%"}); }
  ExprPtr power() { return binary_chain(&ExprParser::unary, {"**"}); }
  // jinja2/parser.py parse_unary: a sign applies to the value with its postfix (.attr, [item],
  // call) but before filters and tests, so -1|abs is abs(-1) and -2 ** 2 is (-2) ** 2.
  ExprPtr unary() { return unary_with(true); }
  ExprPtr unary_with(bool with_filter) {
    Guard g(*this);
    ExprPtr node;
    if (is_op("-") || is_op("+")) {
      const Token t = next();
      node = make(Expr::Kind::unary, t.line);
      node->text = t.text;
      node->args.push_back(unary_with(false));
      node = seal(std::move(node));
    } else {
      node = primary();
    }
    node = postfix(std::move(node));
    if (with_filter) node = filters(std::move(node));
    return node;
  }

  void call_args(Expr& e) {
    expect_op("(");
    while (!is_op(")")) {
      if (peek().kind == Token::Kind::name && is_op("=", 1)) {
        std::string key = next().text;
        next();
        e.kwargs.emplace_back(std::move(key), expression());
      } else {
        if (!e.kwargs.empty()) fail("a positional argument after a keyword argument");
        e.args.push_back(expression());
      }
      if (!is_op(",")) break;
      next();
    }
    expect_op(")");
  }

  ExprPtr postfix(ExprPtr e) {
    while (true) {
      if (is_op(".")) {
        const std::uint32_t line = next().line;
        ExprPtr a = make(Expr::Kind::attr, line);
        if (peek().kind == Token::Kind::integer) {
          a->kind = Expr::Kind::item;  // Jinja: x.0 is x[0]
          a->args.push_back(std::move(e));
          ExprPtr idx = make(Expr::Kind::literal, line);
          idx->value = next().value;
          a->args.push_back(std::move(idx));
        } else {
          a->text = expect_name();
          a->args.push_back(std::move(e));
        }
        e = seal(std::move(a));
      } else if (is_op("[")) {
        const std::uint32_t line = next().line;
        ExprPtr a = make(Expr::Kind::item, line);
        a->args.push_back(std::move(e));
        if (is_op(":")) fail("slices are not supported");
        a->args.push_back(expression());
        if (is_op(":")) fail("slices are not supported");
        expect_op("]");
        e = seal(std::move(a));
      } else if (is_op("(")) {
        ExprPtr c = make(Expr::Kind::call, peek().line);
        c->args.push_back(std::move(e));
        call_args(*c);
        e = seal(std::move(c));
      } else {
        return e;
      }
    }
  }

  /// jinja2/parser.py parse_filter_expr: filters, tests and calls after them.
  ExprPtr filters(ExprPtr e) {
    while (true) {
      if (is_op("(")) {
        ExprPtr c = make(Expr::Kind::call, peek().line);
        c->args.push_back(std::move(e));
        call_args(*c);
        e = seal(std::move(c));
      } else if (is_op("|")) {
        const std::uint32_t line = next().line;
        ExprPtr f = make(Expr::Kind::filter, line);
        f->text = expect_name();
        f->args.push_back(std::move(e));
        if (is_op("(")) call_args(*f);
        e = seal(std::move(f));
      } else if (is_name("is")) {
        const std::uint32_t line = next().line;
        ExprPtr t = make(Expr::Kind::test, line);
        if (is_name("not")) {
          next();
          t->negated = true;
        }
        t->text = expect_name();
        t->args.push_back(std::move(e));
        if (is_op("(")) {
          call_args(*t);
        } else if (peek().kind == Token::Kind::integer || peek().kind == Token::Kind::number ||
                   peek().kind == Token::Kind::string) {
          ExprPtr arg = make(Expr::Kind::literal, peek().line);  // `is divisibleby 3`
          arg->value = next().value;
          t->args.push_back(std::move(arg));
        }
        e = seal(std::move(t));
      } else {
        return e;
      }
    }
  }

  ExprPtr primary() {
    Guard g(*this);
    const Token& t = peek();
    switch (t.kind) {
      case Token::Kind::integer:
      case Token::Kind::number:
      case Token::Kind::string: {
        ExprPtr e = make(Expr::Kind::literal, t.line);
        e->value = next().value;
        // Adjacent string literals concatenate, as in Python and Jinja.
        while (e->value.type() == Value::Type::string && peek().kind == Token::Kind::string) {
          e->value = Value::string(e->value.text() + next().text);
        }
        return e;
      }
      case Token::Kind::name: {
        const Token n = next();
        ExprPtr e = make(Expr::Kind::literal, n.line);
        if (n.text == "true" || n.text == "True") {
          e->value = Value::boolean(true);
        } else if (n.text == "false" || n.text == "False") {
          e->value = Value::boolean(false);
        } else if (n.text == "none" || n.text == "None") {
          e->value = Value::none();
        } else {
          e->kind = Expr::Kind::name;
          e->text = n.text;
        }
        return e;
      }
      case Token::Kind::op:
        if (t.text == "(") {
          next();
          if (is_op(")")) {
            next();
            ExprPtr empty = make(Expr::Kind::list, t.line);
            empty->tuple = true;
            return empty;
          }
          ExprPtr inner = tuple_or_expression();
          expect_op(")");
          return inner;
        }
        if (t.text == "[") {
          ExprPtr l = make(Expr::Kind::list, next().line);
          while (!is_op("]")) {
            l->args.push_back(expression());
            if (!is_op(",")) break;
            next();
          }
          expect_op("]");
          return seal(std::move(l));
        }
        if (t.text == "{") {
          ExprPtr d = make(Expr::Kind::dict, next().line);
          while (!is_op("}")) {
            d->keys.push_back(expression());
            expect_op(":");
            d->args.push_back(expression());
            if (!is_op(",")) break;
            next();
          }
          expect_op("}");
          return seal(std::move(d));
        }
        break;
      case Token::Kind::end: break;
    }
    fail("expected a value");
  }

  std::vector<Token> t_;
  std::size_t i_ = 0;
  int depth_ = 0;
};

/// One piece of the template: text, an expression or a statement (its tokens).
struct Piece {
  enum class Kind : std::uint8_t { text, output, statement };
  Kind kind = Kind::text;
  std::uint32_t line = 0;
  std::string text;
  std::vector<Token> tokens;
};

std::vector<Piece> cut(std::string_view s) {
  std::vector<Piece> pieces;
  std::size_t pos = 0;
  std::uint32_t line = 1;
  bool strip_next = false;
  auto add_text = [&](std::string_view text, std::uint32_t at) {
    if (strip_next) {
      const std::size_t b = text.find_first_not_of(" \t\r\n");
      for (std::size_t i = 0; i < (b == std::string_view::npos ? text.size() : b); ++i) {
        if (text[i] == '\n') ++at;
      }
      text = b == std::string_view::npos ? std::string_view() : text.substr(b);
      strip_next = false;
    }
    if (!text.empty()) pieces.push_back({Piece::Kind::text, at, std::string(text), {}});
  };
  auto strip_before = [&] {
    if (!pieces.empty() && pieces.back().kind == Piece::Kind::text) {
      std::string& t = pieces.back().text;
      t.erase(t.find_last_not_of(" \t\r\n") + 1);
      if (t.empty()) pieces.pop_back();
    }
  };
  while (pos < s.size()) {
    const std::size_t open = s.find('{', pos);
    const std::size_t text_end = open == std::string_view::npos ? s.size() : open;
    const std::uint32_t text_line = line;
    for (std::size_t i = pos; i < text_end; ++i) {
      if (s[i] == '\n') ++line;
    }
    add_text(s.substr(pos, text_end - pos), text_line);
    if (open == std::string_view::npos) break;
    const std::uint32_t at = line;
    const char kind = open + 1 < s.size() ? s[open + 1] : '\0';
    if (kind == '#') {
      std::size_t close = s.find("#}", open + 2);
      if (close == std::string_view::npos) throw TemplateError(at, "'{#' is never closed by '#}'");
      if (open + 2 < s.size() && s[open + 2] == '-') strip_before();
      const bool strip_after = close > open + 2 && s[close - 1] == '-';
      for (std::size_t i = open; i < close; ++i) {
        if (s[i] == '\n') ++line;
      }
      pos = close + 2;
      strip_next = strip_after;
      continue;
    }
    if (kind == '%') {
      pos = open + 2;
      if (pos < s.size() && s[pos] == '-') {
        strip_before();
        ++pos;
      } else if (pos < s.size() && s[pos] == '+') {
        ++pos;
      }
      bool strip_after = false;
      Piece p{Piece::Kind::statement, at, {}, tokenize(s, pos, line, true, strip_after, at)};
      pieces.push_back(std::move(p));
      strip_next = strip_after;
      continue;
    }
    pos = open + 1;
    if (pos < s.size() && s[pos] == '-') {  // "{-": strips the whitespace before, even "{-1}"
      strip_before();
      ++pos;
    }
    bool strip_after = false;
    Piece p{Piece::Kind::output, at, {}, tokenize(s, pos, line, false, strip_after, at)};
    if (p.tokens.size() == 1) throw TemplateError(at, "empty expression '{}'");
    pieces.push_back(std::move(p));
    strip_next = strip_after;
  }
  return pieces;
}

/// Statements over the pieces: if/elif/else/endif, for/else/endfor, set.
class BodyParser {
 public:
  explicit BodyParser(std::vector<Piece> pieces) : p_(std::move(pieces)) {}

  NodeList parse_all() {
    NodeList out = parse_until({});
    return out;
  }

 private:
  static std::string keyword(const Piece& p) {
    return p.tokens.front().kind == Token::Kind::name ? p.tokens.front().text : std::string();
  }

  /// Parses nodes until a statement whose keyword is in `stop` (left unconsumed).
  NodeList parse_until(std::initializer_list<std::string_view> stop) {
    if (++depth_ > kMaxDepth) nesting_error(line(), "statement");
    NodeList out;
    while (i_ < p_.size()) {
      Piece& piece = p_[i_];
      if (piece.kind == Piece::Kind::text) {
        Node n;
        n.kind = Node::Kind::text;
        n.line = piece.line;
        n.text = std::move(piece.text);
        out.push_back(std::move(n));
        ++i_;
        continue;
      }
      if (piece.kind == Piece::Kind::output) {
        ExprParser ep(std::move(piece.tokens));
        Node n;
        n.kind = Node::Kind::output;
        n.line = piece.line;
        n.expr = ep.expression();
        ep.expect_end();
        out.push_back(std::move(n));
        ++i_;
        continue;
      }
      const std::string kw = keyword(piece);
      for (std::string_view s : stop) {
        if (kw == s) {
          --depth_;
          return out;
        }
      }
      if (kw == "if") {
        out.push_back(parse_if());
      } else if (kw == "for") {
        out.push_back(parse_for());
      } else if (kw == "set") {
        out.push_back(parse_set());
      } else if (kw == "endif" || kw == "endfor" || kw == "elif" || kw == "else") {
        throw TemplateError(piece.line, fmt::format("'{{% {} %}}' without its opening statement", kw));
      } else {
        throw TemplateError(piece.line, fmt::format("statement '{{% {} %}}' is not supported",
                                                    kw.empty() ? piece.tokens.front().text : kw));
      }
    }
    if (stop.size() != 0) {
      throw TemplateError(line(), fmt::format("'{{% {} %}}' is missing", *std::prev(stop.end())));
    }
    --depth_;
    return out;
  }

  std::uint32_t line() const { return p_.empty() ? 1 : p_[std::min(i_, p_.size() - 1)].line; }

  ExprParser open(std::size_t skip) {
    ExprParser ep(std::move(p_[i_].tokens));
    for (std::size_t k = 0; k < skip; ++k) ep.next();
    ++i_;
    return ep;
  }

  Node parse_if() {
    Node n;
    n.kind = Node::Kind::if_;
    n.line = p_[i_].line;
    ExprParser ep = open(1);
    ExprPtr cond = ep.expression();
    ep.expect_end();
    while (true) {
      NodeList body = parse_until({"elif", "else", "endif"});
      n.branches.emplace_back(std::move(cond), std::move(body));
      const std::string kw = keyword(p_[i_]);
      if (kw == "elif") {
        ExprParser e2 = open(1);
        cond = e2.expression();
        e2.expect_end();
        continue;
      }
      if (kw == "else") {
        open(1).expect_end();
        n.else_body = parse_until({"endif"});
      }
      open(1).expect_end();  // endif
      return n;
    }
  }

  Node parse_for() {
    Node n;
    n.kind = Node::Kind::for_;
    n.line = p_[i_].line;
    ExprParser ep = open(1);
    n.targets.push_back(ep.expect_name());
    while (ep.is_op(",")) {
      ep.next();
      n.targets.push_back(ep.expect_name());
    }
    if (!ep.is_name("in")) ep.fail("expected 'in'");
    ep.next();
    n.expr = ep.tuple_or_expression();
    if (ep.is_name("if")) ep.fail("a loop filter ('for ... if ...') is not supported");
    if (ep.is_name("recursive")) ep.fail("recursive loops are not supported");
    ep.expect_end();
    NodeList body = parse_until({"else", "endfor"});
    n.branches.emplace_back(nullptr, std::move(body));
    if (keyword(p_[i_]) == "else") {
      open(1).expect_end();
      n.else_body = parse_until({"endfor"});
    }
    open(1).expect_end();
    return n;
  }

  Node parse_set() {
    Node n;
    n.kind = Node::Kind::set;
    n.line = p_[i_].line;
    ExprParser ep = open(1);
    n.targets.push_back(ep.expect_name());
    if (ep.is_op(".")) {
      ep.next();
      n.targets.push_back(ep.expect_name());
      n.attr_target = true;
    } else {
      while (ep.is_op(",")) {
        ep.next();
        n.targets.push_back(ep.expect_name());
      }
    }
    if (!ep.is_op("=")) ep.fail("block assignment ('{% set x %}...{% endset %}') is not supported; expected '='");
    ep.next();
    n.expr = ep.tuple_or_expression();
    ep.expect_end();
    return n;
  }

  std::vector<Piece> p_;
  std::size_t i_ = 0;
  int depth_ = 0;
};

}  // namespace

std::shared_ptr<const Body> parse_template(std::string_view text) {
  auto body = std::make_shared<Body>();
  body->nodes = BodyParser(cut(text)).parse_all();
  return body;
}

ExprPtr parse_expression(std::string_view text) {
  std::string closed(text);
  closed += '}';
  std::size_t pos = 0;
  std::uint32_t line = 1;
  bool unused = false;
  ExprParser ep(tokenize(closed, pos, line, false, unused, 1));
  if (pos != closed.size()) throw TemplateError(line, "unexpected '}'");
  ExprPtr e = ep.tuple_or_expression();
  ep.expect_end();
  return e;
}

}  // namespace detail
}  // namespace amctl::macro
