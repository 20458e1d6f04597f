// The template evaluator against the real Jinja2: every case of
// tests/reference/macro/jinja_cases.json rendered by Jinja2 3.1 in Klipper's environment
// (tests/reference/macro/jinja_cases.py wrote jinja_expected.json) must render to the same
// text here, and the cases that fail in Jinja2 must fail here. Then the limits and the
// literals of variable_* options, with values from Python's ast.literal_eval.
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "amctl/macro/template.hpp"

namespace amctl::macro {
namespace {

using Json = nlohmann::json;

Json read_json(const std::string& name) {
  std::ifstream in(std::string(AMCTL_SOURCE_DIR) + "/tests/reference/macro/" + name);
  EXPECT_TRUE(in.good()) << name;
  return Json::parse(in);
}

Value to_value(const Json& j, bool coord = false) {
  if (j.is_boolean()) return Value::boolean(j.get<bool>());
  if (j.is_number_integer()) return Value::integer(j.get<std::int64_t>());
  if (j.is_number()) return Value::number(j.get<double>());
  if (j.is_string()) return Value::string(j.get<std::string>());
  if (j.is_null()) return Value::none();
  if (j.is_array()) {
    List l;
    for (const Json& e : j) l.push_back(to_value(e));
    return Value::list(std::move(l), coord);
  }
  Dict d;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const bool c = it.key() == "position" || it.key() == "gcode_position" ||
                   it.key() == "axis_minimum" || it.key() == "axis_maximum";
    d.set(it.key(), to_value(it.value(), c));
  }
  return Value::dict(std::move(d));
}

Dict globals_of(const Json& c) {
  Dict g;
  if (c.contains("variables")) {
    for (auto it = c["variables"].begin(); it != c["variables"].end(); ++it) {
      g.set(it.key(), to_value(it.value()));
    }
  }
  g.set("printer", to_value(c.value("printer", Json::object())));
  g.set("params", to_value(c.value("params", Json::object())));
  g.set("rawparams", Value::string(c.value("rawparams", std::string())));
  g.set("action_respond_info", Value::function("action_respond_info"));
  g.set("action_raise_error", Value::function("action_raise_error"));
  return g;
}

TEST(Template, RendersEveryReferenceCaseAsJinja2Does) {
  const Json cases = read_json("jinja_cases.json");
  const Json expected = read_json("jinja_expected.json");
  ASSERT_EQ(cases.size(), expected.size());
  ASSERT_GE(cases.size(), 50u);
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const Json& c = cases[i];
    const Json& want = expected[i];
    ASSERT_EQ(c["name"], want["name"]);
    const std::string name = c["name"];
    if (want["error"].get<bool>()) {
      EXPECT_THROW((void)Template::compile(c["template"].get<std::string>()).render(globals_of(c)),
                   TemplateError)
          << name;
      continue;
    }
    try {
      const std::string got =
          Template::compile(c["template"].get<std::string>()).render(globals_of(c));
      EXPECT_EQ(got, want["output"].get<std::string>()) << name;
    } catch (const TemplateError& e) {
      ADD_FAILURE() << name << ": line " << e.line() << ": " << e.what();
    }
  }
}

std::string render(const std::string& text, const Dict& g = {}, RenderLimits lim = {}) {
  return Template::compile(text).render(g, lim);
}

std::string error_of(const std::string& text, RenderLimits lim = {}) {
  try {
    (void)render(text, {}, lim);
  } catch (const TemplateError& e) {
    return std::to_string(e.line()) + ": " + e.what();
  }
  return "no error";
}

TEST(Template, UnsupportedConstructsNameTheirLine) {
  EXPECT_EQ(error_of("G1\n{% macro m() %}{% endmacro %}"),
            "2: statement '{% macro %}' is not supported");
  EXPECT_EQ(error_of("A\nB\n{ x[1:2] }"), "3: slices are not supported, found ':'");
  EXPECT_EQ(error_of("{% if 1 %}\nG1\n"), "1: '{% endif %}' is missing");
  EXPECT_EQ(error_of("X{ 1 + }"), "1: expected a value, found the end");
  EXPECT_EQ(error_of("{ 'abc'|wordwrap }"), "1: filter 'wordwrap' is not supported");
  EXPECT_EQ(error_of("\n{ params.X + 1 }"), "2: 'params' is undefined");
  EXPECT_EQ(error_of("{ 1"), "1: '{' is never closed by '}'");
}

TEST(Template, LoopsAndOutputAreBounded) {
  RenderLimits lim;
  lim.max_loop_iterations = 1000;
  EXPECT_EQ(error_of("{% for i in range(10) %}{% for j in range(200) %}{% endfor %}{% endfor %}", lim),
            "1: loop limit: the render makes more than 1000 loop iterations, expected at most 1000");
  EXPECT_EQ(error_of("{ range(100000000)|length }"),
            "1: range limit: found range() of 100000000 values, expected at most 1000000");
  lim = {};
  lim.max_output_bytes = 100;
  EXPECT_EQ(error_of("{% for i in range(100) %}G1 X{i}\n{% endfor %}", lim),
            "1: output limit: the render writes more than 100 bytes, expected at most 100");
  // Deep nesting is an error, not a stack overflow.
  EXPECT_EQ(error_of("{ " + std::string(5000, '(') + "1" + std::string(5000, ')') + " }"),
            "1: nesting limit: found expression nested more than 200 deep (a chain such as a|f|f, "
            "a.b.c or 1+1+1 counts one level per link), expected at most 200");
  EXPECT_EQ(error_of("{ 2 ** 64 }"), "1: integer overflow (beyond 64 bits)");
}

TEST(Template, MutatedTemplatesRenderOrFailWithATemplateError) {
  // Seeded mutations of every reference template: any outcome but a TemplateError or a
  // rendered text (a crash, another exception, a hang) fails.
  const Json cases = read_json("jinja_cases.json");
  std::mt19937 rng(14);
  const std::string alphabet = "{}%#-|()[]'\".,:=+*/~ \n0a9Z_";
  RenderLimits lim;
  lim.max_loop_iterations = 10000;
  lim.max_output_bytes = 1 << 16;
  std::size_t rendered = 0, refused = 0;
  for (const Json& c : cases) {
    const Dict g = globals_of(c);
    for (int k = 0; k < 60; ++k) {
      std::string t = c["template"];
      const int edits = 1 + static_cast<int>(rng() % 3);
      for (int e = 0; e < edits; ++e) {
        const std::size_t at = t.empty() ? 0 : rng() % t.size();
        const char ch = alphabet[rng() % alphabet.size()];
        switch (rng() % 3) {
          case 0: if (!t.empty()) t[at] = ch; break;
          case 1: t.insert(t.begin() + static_cast<std::ptrdiff_t>(at), ch); break;
          default: if (!t.empty()) t.erase(at, 1 + rng() % 4);
        }
      }
      try {
        (void)Template::compile(t).render(g, lim);
        ++rendered;
      } catch (const TemplateError&) {
        ++refused;
      }
    }
  }
  EXPECT_GT(rendered, 100u);
  EXPECT_GT(refused, 100u);
}

TEST(Template, AListBuiltIntoItselfIsBounded) {
  EXPECT_EQ(error_of("{% set ns = namespace(v=[]) %}{% for i in range(100000) %}"
                     "{% set ns.v = [ns.v] %}{% endfor %}{ ns.v }"),
            "1: nesting limit: found lists or dicts nested more than 100 deep, expected at most 100");
}

/// The kind of a failure: "limit" (LimitError), "template" (another TemplateError) or "none".
std::string failure_kind(const std::string& text, RenderLimits lim = {}) {
  try {
    (void)render(text, {}, lim);
  } catch (const LimitError&) {
    return "limit";
  } catch (const TemplateError&) {
    return "template";
  }
  return "none";
}

std::string repeat(const std::string& s, int n) {
  std::string out;
  for (int i = 0; i < n; ++i) out += s;
  return out;
}

// Chains the parser builds in loops (filters, attribute lookups, items, calls, + terms, and,
// or, comparisons' operands) count one nesting level per link: 100 000 links are a
// LimitError at the template line, not a stack overflow when the tree is evaluated or freed.
TEST(TemplateLimits, LongChainsInOneExpressionAreANestingError) {
  const std::vector<std::string> chains = {
      "{ 1" + repeat("|abs", 100000) + " }",
      "{ x" + repeat(".a", 100000) + " }",
      "{ x" + repeat("[0]", 100000) + " }",
      "{ 1" + repeat(" + 1", 100000) + " }",
      "{ 1" + repeat(" ~ 1", 100000) + " }",
      "{ 1" + repeat(" and 1", 100000) + " }",
      "{ 1" + repeat(" or 1", 100000) + " }",
      "{ 2" + repeat(" ** 2", 100000) + " }",
      "{ range" + repeat("(1)", 100000) + " }",
      "{ 1" + repeat(" is number", 100000) + " }",
      "{ " + repeat("not ", 100000) + "1 }",
      "{ " + repeat("-", 100000) + "1 }",
      "{ " + repeat("[", 100000) + repeat("]", 100000) + " }",
      "{% set x = 1" + repeat("|abs", 100000) + " %}",
      "{% if 1 %}" + repeat("{% if 1 %}", 300) + repeat("{% endif %}", 301),
  };
  for (const std::string& t : chains) {
    try {
      (void)Template::compile("G1\n" + t);
      ADD_FAILURE() << t.substr(0, 40) << ": compiled";
    } catch (const LimitError& e) {
      EXPECT_EQ(e.line(), 2u) << t.substr(0, 40);
      EXPECT_NE(std::string(e.what()).find("nested more than 200 deep"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("nesting limit"), std::string::npos) << e.what();
    }
  }
  // Just within the bound: evaluates.
  EXPECT_EQ(render("{ 1" + repeat("|abs", 150) + " }"), "1");
  EXPECT_EQ(render("{ 0" + repeat(" + 1", 150) + " }"), "150");
}

TEST(TemplateLimits, AHugeTemplateIsRefusedBeforeItIsParsed) {
  EXPECT_THROW((void)Template::compile(std::string(kMaxTemplateBytes + 1, 'x')), LimitError);
  EXPECT_NO_THROW((void)Template::compile(std::string(100000, 'x')));
}

// Doubling a string or a list in a loop, amplifying with replace or join, or a list shared
// into itself: each stops at its bound with a LimitError, never bad_alloc.
TEST(TemplateLimits, AnEmptyValueRepeatedIsEmptyAtOnce) {
  // Found by fuzzing: '' * n looped n times with nothing counted (13 s for n near 1e9).
  EXPECT_EQ(render("{ ('' * 4000000000000000000)|length } { ([] * 4000000000000000000)|length }"), "0 0");
  EXPECT_EQ(render("{ (undefined_name|lower * 928809768)|length }"), "0");
}

TEST(TemplateLimits, StringsListsAndMemoryAreBounded) {
  EXPECT_EQ(failure_kind("{% set ns = namespace(s='x') %}{% for i in range(64) %}"
                         "{% set ns.s = ns.s ~ ns.s %}{% endfor %}{ ns.s|length }"),
            "limit");
  EXPECT_EQ(failure_kind("{% set ns = namespace(s='x') %}{% for i in range(64) %}"
                         "{% set ns.s = ns.s + ns.s %}{% endfor %}"),
            "limit");
  EXPECT_EQ(failure_kind("{% set ns = namespace(l=[1]) %}{% for i in range(64) %}"
                         "{% set ns.l = ns.l + ns.l %}{% endfor %}"),
            "limit");
  EXPECT_EQ(failure_kind("{% set ns = namespace(l=[1]) %}{% for i in range(64) %}"
                         "{% set ns.l = [ns.l, ns.l] %}{% endfor %}{ ns.l }"),
            "limit");
  EXPECT_EQ(failure_kind("{ ('x' * 1000)|replace('x', 'y' * 100000) }"), "limit");
  EXPECT_EQ(failure_kind("{ ('x' * 1000).replace('x', 'y' * 100000) }"), "limit");
  EXPECT_EQ(failure_kind("{ ['y' * 1000000] * 1000000 }"), "limit");
  EXPECT_EQ(failure_kind("{ (['y' * 100000] * 1000)|join('z' * 100000) }"), "limit");
  EXPECT_EQ(failure_kind("{ 'x' * 100000000 }"), "limit");
  EXPECT_EQ(failure_kind("{% for i in range(100000) %}{% set s = 'x' * 10000 %}{% endfor %}"), "limit");
  // Within the bounds, the same operations give Python's answers.
  EXPECT_EQ(render("{ 'abc'|replace('', '-') }"), "-a-b-c-");
  EXPECT_EQ(render("{ 'aaa'.replace('a', 'bb') }"), "bbbbbb");
  EXPECT_EQ(render("{ ('ab' * 3)|length }"), "6");
  EXPECT_EQ(render("{ ([1, 2] * 2)|join(',') }"), "1,2,1,2");
}

TEST(TemplateLimits, RangesNearTheIntegerLimitsAreExactOrRefused) {
  EXPECT_EQ(render("{ range(9223372036854775800, 9223372036854775807)|list|length }"), "7");
  EXPECT_EQ(render("{ range(9223372036854775806, 9223372036854775807, 5)|list }"), "[9223372036854775806]");
  EXPECT_EQ(render("{ range(-9223372036854775807, -9223372036854775804)|list }"),
            "[-9223372036854775807, -9223372036854775806, -9223372036854775805]");
  EXPECT_EQ(render("{ range(5, -5, -3)|list }"), "[5, 2, -1, -4]");
  EXPECT_EQ(failure_kind("{ range(-9223372036854775807, 9223372036854775807)|length }"), "limit");
  EXPECT_EQ(failure_kind("{ range(0, 9223372036854775807, 2) }"), "limit");
  EXPECT_EQ(render("{ (-1) ** 3 }|{ (-1) ** 4 }|{ (-1) ** 9223372036854775807 }"), "-1|1|-1");
}

TEST(TemplateLimits, WorkIsBounded) {
  // A million iterations each scanning a long string: the work bound, not minutes of CPU.
  EXPECT_EQ(failure_kind("{% set s = 'x' * 1000000 %}{% for i in range(1000000) %}"
                         "{% if 'y' in s %}{% endif %}{% endfor %}"),
            "limit");
  EXPECT_EQ(failure_kind("{% set l = range(1000000)|list %}{% for i in range(1000) %}"
                         "{% if l == l %}{% endif %}{% endfor %}"),
            "limit");
  RenderLimits lim;
  lim.max_work = 1000;
  EXPECT_EQ(failure_kind("{% for i in range(500) %}{ i }{% endfor %}", lim), "limit");
  EXPECT_EQ(failure_kind("{% for i in range(20) %}{ i }{% endfor %}", lim), "none");
}

TEST(Template, LiteralsAreReadAsPythonsLiteralEval) {
  EXPECT_EQ(parse_literal("0"), Value::integer(0));
  EXPECT_EQ(parse_literal(" -2.5 "), Value::number(-2.5));
  EXPECT_EQ(parse_literal("'PLA'"), Value::string("PLA"));
  EXPECT_EQ(parse_literal("True"), Value::boolean(true));
  EXPECT_EQ(parse_literal("None"), Value::none());
  EXPECT_EQ(parse_literal("[1, 2.5, 'a']").str(), "[1, 2.5, 'a']");
  EXPECT_EQ(parse_literal("(1, 2)").str(), "(1, 2)");
  EXPECT_EQ(parse_literal("{'a': 1, 'b': [2]}").str(), "{'a': 1, 'b': [2]}");
  EXPECT_THROW(parse_literal("PLA"), TemplateError);   // a bare word is no literal (needs quotes)
  EXPECT_THROW(parse_literal("true"), TemplateError);  // Python spells it True
  EXPECT_THROW(parse_literal("1 + 2"), TemplateError);
}

TEST(Template, FloatsPrintAsPythonRepr) {
  EXPECT_EQ(python_float_repr(200.0), "200.0");
  EXPECT_EQ(python_float_repr(0.1), "0.1");
  EXPECT_EQ(python_float_repr(1e-4), "0.0001");
  EXPECT_EQ(python_float_repr(1e-5), "1e-05");
  EXPECT_EQ(python_float_repr(1e16), "1e+16");
  EXPECT_EQ(python_float_repr(9999999999999998.0), "9999999999999998.0");
  EXPECT_EQ(python_float_repr(-0.0), "-0.0");
  EXPECT_EQ(python_float_repr(1.2345678901234567e+100), "1.2345678901234567e+100");
}

}  // namespace
}  // namespace amctl::macro
