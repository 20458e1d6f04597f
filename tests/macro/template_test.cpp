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
            "1: more than 1000 loop iterations");
  EXPECT_EQ(error_of("{ range(100000000)|length }"),
            "1: range() of 100000000 values (more than 1000000)");
  lim = {};
  lim.max_output_bytes = 100;
  EXPECT_EQ(error_of("{% for i in range(100) %}G1 X{i}\n{% endfor %}", lim),
            "1: the macro's output exceeds 100 bytes");
  // Deep nesting is an error, not a stack overflow.
  EXPECT_EQ(error_of("{ " + std::string(5000, '(') + "1" + std::string(5000, ')') + " }"),
            "1: expression nested too deeply, found '('");
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
            "1: lists or dicts nested too deeply");
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
