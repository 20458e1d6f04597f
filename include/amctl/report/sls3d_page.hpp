#pragma once
// The page of `amctl thermal sls3d --report OUT.html` (docs/sls3d.md, section 6): one
// self-contained HTML file, no script and nothing loaded: the top-surface temperature maps
// at the snapshot instants (PNG images inlined as data URIs, one colour scale), U(t) with the
// saturation limits and the saturated samples, y(t) against the set point (inline SVG charts,
// report/line_chart.hpp), and the run's figures.
#include <string>
#include <vector>

#include "amctl/sls3d/studies.hpp"

namespace amctl::report {

/// The HTML page.
[[nodiscard]] std::string sls3d_page_html(const sls3d::ScenarioResult& r);

/// sls3d_page_html written to `path` through a temporary file renamed into place.
void write_sls3d_report(const sls3d::ScenarioResult& r, const std::string& path);

/// An 8-bit RGBA image as a PNG file (stored, uncompressed deflate blocks; CRC-32 and
/// Adler-32 as the PNG and zlib specifications define them). rgba has 4 width height bytes.
[[nodiscard]] std::string png_rgba(int width, int height, const std::vector<unsigned char>& rgba);

}  // namespace amctl::report
