#pragma once
// The page around the report's JSON: page_head() + JSON + page_tail() is the whole file.
// Styles and the drawing script are inline (src/report/page.cpp); nothing is loaded.
#include <string_view>

namespace amctl::report {

/// Everything before the JSON, ending inside <script type="application/json" id="data">.
[[nodiscard]] std::string_view page_head();
/// Everything after it: the closing tag, the drawing script, the end of the document.
[[nodiscard]] std::string_view page_tail();

}  // namespace amctl::report
