#!/usr/bin/python3
"""Checks a headless-Chromium screenshot of an amctl report as a person would look at it.

Usage: check_page_screenshot.py SCREENSHOT.png CHROMIUM_LOG DUMPED_DOM [ZOOMED.png]

- the speed plot is drawn: a wide, tall region of its min-max band colour (#a9c8e4), well
  filled, with the mean-speed line (#0b4f8a, anti-aliased: pixels close to it) across it;
- the time-per-layer bars are drawn (#5a8dc0);
- the toolpath is drawn below them in several colours of the speed scale;
- the page's script ran to its end (data-drawn="yes" in the DOM Chromium dumped);
- zoomed in (the page opened at #t=A-B), the speed plot is drawn again from the buckets;
- the console shows no blocked request (Content-Security-Policy), no script error and no URL.
The PNG is decoded here with zlib (filters undone by hand); no imaging library needed.
"""
import re
import struct
import sys
import zlib


def read_png(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat = 8, []
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            w, h, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and ctype in (2, 6) and interlace == 0, (depth, ctype, interlace)
        elif kind == b"IDAT":
            idat.append(body)
    bpp = 3 if ctype == 2 else 4
    raw = zlib.decompress(b"".join(idat))
    stride = w * bpp
    rows, prev = [], bytearray(stride)
    for y in range(h):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        if f == 1:
            for i in range(bpp, stride):
                line[i] = (line[i] + line[i - bpp]) & 255
        elif f == 2:
            line = bytearray((a + b) & 255 for a, b in zip(line, prev))
        elif f == 3:
            for i in range(stride):
                left = line[i - bpp] if i >= bpp else 0
                line[i] = (line[i] + ((left + prev[i]) >> 1)) & 255
        elif f == 4:
            for i in range(stride):
                a = line[i - bpp] if i >= bpp else 0
                b = prev[i]
                c = prev[i - bpp] if i >= bpp else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line))
        prev = line
    return w, h, bpp, rows


def main():
    png, log, dom = sys.argv[1:4]
    w, h, bpp, rows = read_png(png)
    failures = []
    band = bytes((169, 200, 228))
    line = (11, 79, 138)

    def near_line(c):
        return all(abs(c[i] - line[i]) <= 40 for i in range(3))
    if len(sys.argv) > 4:
        zw, zh, zbpp, zrows = read_png(sys.argv[4])
        xs = [x for row in zrows for x in range(zw) if row[x * zbpp:x * zbpp + 3] == band]
        span = (max(xs) - min(xs) + 1) if xs else 0
        print(f"zoomed speed band: {len(xs)} px over {span} px")
        if span < zw // 2 or len(xs) < 5000:
            failures.append("zoomed in, the speed plot is not drawn")

    def pixels():
        for y, row in enumerate(rows):
            for x in range(w):
                yield x, y, row[x * bpp:x * bpp + 3]

    bars = bytes((90, 141, 192))
    band_box, band_n, bars_n, bars_bottom = [w, h, -1, -1], 0, 0, -1
    line_xs = set()
    colours = {}
    for x, y, c in pixels():
        if near_line(c):
            line_xs.add(x)
        if c == band:
            band_n += 1
            band_box = [min(band_box[0], x), min(band_box[1], y), max(band_box[2], x), max(band_box[3], y)]
        elif c == bars:
            bars_n += 1
            bars_bottom = max(bars_bottom, y)
        colours[c] = colours.get(c, 0) + 1
    bw, bh = band_box[2] - band_box[0] + 1, band_box[3] - band_box[1] + 1
    print(f"speed band: {band_n} px in {bw} x {bh}; layer bars: {bars_n} px; {len(colours)} colours")
    if bw < w // 2 or bh < 100 or band_n < 0.15 * bw * bh:
        failures.append("the speed plot is not drawn (too few band pixels)")
    line_span = len([x for x in line_xs if band_box[0] <= x <= band_box[2]])
    print(f"mean-speed line over {line_span} of the band's {bw} columns")
    if line_span < 0.8 * bw:
        failures.append("the mean-speed line is not drawn across the speed plot")
    if bars_n < 1000:
        failures.append("the time-per-layer bars are not drawn")
    # Toolpath: saturated pixels below the layer bars, in several colours.
    path_n, path_colours = 0, set()
    for y in range(bars_bottom + 1, h):
        row = rows[y]
        for x in range(w):
            c = row[x * bpp:x * bpp + 3]
            if max(c) - min(c) > 60 and c != band:
                path_n += 1
                path_colours.add(c)
    print(f"toolpath: {path_n} coloured px, {len(path_colours)} colours below the layer bars (y > {bars_bottom})")
    if bars_bottom < 0 or path_n < 500 or len(path_colours) < 8:
        failures.append("the toolpath is not drawn in several colours")
    if len(colours) < 50:
        failures.append("fewer than 50 distinct colours on the page")

    console = [l for l in open(log, errors="replace") if "CONSOLE" in l]
    for l in console:
        if re.search(r"Content Security Policy|Uncaught|https?://|Refused to", l):
            failures.append("console: " + l.strip())
    if 'data-drawn="yes"' not in open(dom, errors="replace").read():
        failures.append("the page's script did not run to its end (no data-drawn=\"yes\")")
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
