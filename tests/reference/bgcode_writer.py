#!/usr/bin/env python3
"""A binary G-code writer, written from Prusa's public specification of the format (version 1)
and the descriptions of heatshrink and MeatPack, independently of amctl's reader. It makes the
test files of tests/formats/ and states the text a reader must give back for each.

    bgcode_writer.py IN.gcode OUT.bgcode [--compression none|deflate|hs11|hs12]
        [--encoding text|meatpack|meatpack-comments] [--checksum crc32|none]
        [--block-bytes N] [--expected OUT.txt]
    bgcode_writer.py --fixtures DIR [--lines N] IN.gcode
        every compression x encoding of IN's first N lines (DIR/NAME_COMP_ENC.bgcode), the text
        a reader must give back for each (.expected.gcode) and those lines (DIR/NAME.gcode)

The format: a file header ("GCDE", version 1 as uint32, checksum type as uint16), then blocks:
a header (type, compression as uint16; uncompressed size as uint32; the compressed size as
uint32 unless compression is 0), the parameters (uint16 encoding; a thumbnail has format,
width, height), the data, and with CRC32 the CRC-32 (zlib's) of header + parameters + data.
Little-endian throughout. Block order: file metadata, printer metadata, thumbnails, print
metadata, slicer metadata, G-code blocks.

heatshrink (window W bits, lookahead L bits) is LZSS: a bit stream, most significant bit of
a byte first, of items "1 + 8-bit literal" or "0 + W-bit (distance - 1) + L-bit (count - 1)";
the last byte is padded with zero bits. This writer matches greedily through a hash of
3-byte prefixes; any valid choice of items decodes to the same bytes.

MeatPack packs the characters 0-9 . space newline G X (codes 0..12 in that order: 0-9, '.',
' ', '\n', 'G', 'X' -> 0..14) two per byte, low nibble first; code 15 says the character
follows as a whole byte (when only the low nibble is 15, that whole byte comes before the high
nibble's character). 0xFF 0xFF + a command byte: 251 packing on, 250 off, 249 reset,
247 "no spaces" on (code 11 then stands for 'E' and a space is sent whole). As PrusaSlicer's
writer does, a G line loses its comment and its spaces (G1X10Y5E.2); a reader puts a space back
before each parameter letter. With "meatpack-comments" a line starting with ';' is sent as
plain text with packing off; with "meatpack" comments are dropped. Empty lines are dropped.
"""
import argparse
import os
import struct
import sys
import zlib

BLOCK_FILE_METADATA, BLOCK_GCODE, BLOCK_SLICER_METADATA = 0, 1, 2
BLOCK_PRINTER_METADATA, BLOCK_PRINT_METADATA, BLOCK_THUMBNAIL = 3, 4, 5
COMPRESSIONS = {"none": 0, "deflate": 1, "hs11": 2, "hs12": 3}
ENCODINGS = {"text": 0, "meatpack": 1, "meatpack-comments": 2}
PARAMETER_LETTERS = set("XYZEFIJRSGPWHCA")


# ---------------------------------------------------------------- heatshrink
class BitWriter:
    def __init__(self):
        self.out = bytearray()
        self.acc = 0
        self.n = 0

    def put(self, value, bits):
        for i in range(bits - 1, -1, -1):
            self.acc = (self.acc << 1) | ((value >> i) & 1)
            self.n += 1
            if self.n == 8:
                self.out.append(self.acc)
                self.acc = self.n = 0

    def finish(self):
        if self.n:
            self.out.append(self.acc << (8 - self.n))
            self.acc = self.n = 0
        return bytes(self.out)


def heatshrink_compress(data, window_bits, lookahead_bits):
    window = 1 << window_bits
    longest = 1 << lookahead_bits
    w = BitWriter()
    heads = {}  # 3-byte prefix -> positions (most recent last)
    i = 0
    while i < len(data):
        best_len, best_dist = 0, 0
        if i + 3 <= len(data):
            for p in reversed(heads.get(data[i:i + 3], [])[-64:]):
                dist = i - p
                if dist > window:
                    break
                n = 0
                while n < longest and i + n < len(data) and data[p + n] == data[i + n]:
                    n += 1  # may run into the bytes being written: an overlapping copy
                if n > best_len:
                    best_len, best_dist = n, dist
                    if n == longest:
                        break
        take = best_len if best_len >= 2 else 1
        for k in range(i, min(i + take, len(data) - 2)):
            heads.setdefault(data[k:k + 3], []).append(k)
        if best_len >= 2:
            w.put(0, 1)
            w.put(best_dist - 1, window_bits)
            w.put(best_len - 1, lookahead_bits)
        else:
            w.put(1, 1)
            w.put(data[i], 8)
        i += take
    return w.finish()


def heatshrink_decompress(data, window_bits, lookahead_bits, size):
    """The plain reading of the description above (used to check the writer)."""
    out = bytearray()
    bit = 0
    total = len(data) * 8

    def get(n):
        nonlocal bit
        if bit + n > total:
            return None
        v = 0
        for _ in range(n):
            v = (v << 1) | ((data[bit >> 3] >> (7 - (bit & 7))) & 1)
            bit += 1
        return v

    while len(out) < size:
        tag = get(1)
        if tag is None:
            break
        if tag:
            out.append(get(8))
        else:
            dist, count = get(window_bits) + 1, get(lookahead_bits) + 1
            for _ in range(count):
                out.append(out[-dist])
    return bytes(out)


# ---------------------------------------------------------------- MeatPack
MP_CODES = {c: i for i, c in enumerate("0123456789. \nGX")}
SIGNAL = b"\xff\xff"
PACKING_ON, PACKING_OFF, RESET_ALL, NO_SPACES_ON = 251, 250, 249, 247


def is_g_line(line):
    return len(line) >= 2 and line[0] == "G" and line[1].isdigit()


def meatpack_line_text(line):
    """What a line becomes before packing (None: dropped): its comment and surrounding
    blanks removed, and for a G line every space."""
    body = line.split(";", 1)[0].strip(" \t\r")
    if not body:
        return None
    if is_g_line(body):
        body = body.replace(" ", "")
    return body + "\n"


def meatpack_encode(text, keep_comments, no_spaces=True):
    out = bytearray(SIGNAL + bytes([PACKING_ON]))
    packing = True
    codes = dict(MP_CODES)
    if no_spaces:
        out += SIGNAL + bytes([NO_SPACES_ON])
        del codes[" "]
        codes["E"] = MP_CODES[" "]
    for line in text.split("\n"):
        if keep_comments and line.startswith(";"):
            if packing:
                out += SIGNAL + bytes([PACKING_OFF])
                packing = False
            out += (line + "\n").encode("latin-1")
            continue
        body = meatpack_line_text(line)
        if body is None:
            continue
        if not packing:
            out += SIGNAL + bytes([PACKING_ON])
            packing = True
        chars = body if len(body) % 2 == 0 else body + "\n"  # the pad after '\n' is ignored
        for a, b in zip(chars[0::2], chars[1::2]):
            ca, cb = codes.get(a), codes.get(b)
            if ca is not None and cb is not None:
                out.append(ca | (cb << 4))
            elif ca is not None:
                out += bytes([ca | 0xF0, ord(b)])
            elif cb is not None:
                out += bytes([0x0F | (cb << 4), ord(a)])
            else:
                out += bytes([0xFF, ord(a), ord(b)])
    if not keep_comments:
        out += SIGNAL + bytes([RESET_ALL])
    return bytes(out)


def expected_line(line, encoding):
    """The text a reader gives back for one source line (None: no line)."""
    if encoding == "text":
        out = line
    elif encoding == "meatpack-comments" and line.startswith(";"):
        out = line
    else:
        body = meatpack_line_text(line)
        if body is None:
            return None
        out = body[:-1]
        if is_g_line(out):  # spaces back before the parameter letters
            spaced = out[0]
            for c in out[1:]:
                if c in PARAMETER_LETTERS and spaced[-1] != " ":
                    spaced += " "
                spaced += c
            out = spaced
    stripped = out.strip(" \t")
    if stripped.startswith(";"):
        stripped = stripped[1:].strip(" \t")
    return out if stripped else None  # empty and ';'-only lines are dropped


# ---------------------------------------------------------------- blocks
def block(btype, compression, params, data, checksum):
    if compression == 0:
        stored = data
    elif compression == 1:
        stored = zlib.compress(data, 6)
    else:
        window = 11 if compression == 2 else 12
        stored = heatshrink_compress(data, window, 4)
        assert heatshrink_decompress(stored, window, 4, len(data)) == data
    header = struct.pack("<HHI", btype, compression, len(data))
    if compression != 0:
        header += struct.pack("<I", len(stored))
    body = header + params + stored
    if checksum:
        body += struct.pack("<I", zlib.crc32(header + params + stored) & 0xFFFFFFFF)
    return body


def ini(pairs):
    return "".join(f"{k}={v}\n" for k, v in pairs).encode()


def write_bgcode(text, compression="hs12", encoding="meatpack-comments", checksum=True,
                 block_bytes=65535, print_metadata=None, metadata_compression="none"):
    """Returns (bgcode bytes, expected text)."""
    comp = COMPRESSIONS[compression]
    mcomp = COMPRESSIONS[metadata_compression]
    enc = ENCODINGS[encoding]
    out = bytearray(b"GCDE" + struct.pack("<IH", 1, 1 if checksum else 0))
    meta_params = struct.pack("<H", 0)
    out += block(BLOCK_FILE_METADATA, mcomp, meta_params, ini([("Producer", "bgcode_writer.py")]),
                 checksum)
    out += block(BLOCK_PRINTER_METADATA, mcomp, meta_params,
                 ini([("printer_model", "TEST"), ("nozzle_diameter", "0.4")]), checksum)
    thumb = bytes(range(256)) * 3  # any bytes: a reader skips thumbnails
    out += block(BLOCK_THUMBNAIL, 0, struct.pack("<HHH", 0, 16, 16), thumb, checksum)
    if print_metadata is None:  # as PrusaSlicer: the text's own estimate, else a made-up one
        estimate = "1h 2m 3s"
        for line in text.split("\n"):
            if line.startswith("; estimated printing time (normal mode) = "):
                estimate = line.split("=", 1)[1].strip()
        print_metadata = [("filament used [mm]", "123.45"),
                          ("estimated printing time (normal mode)", estimate)]
    out += block(BLOCK_PRINT_METADATA, mcomp, meta_params, ini(print_metadata), checksum)
    out += block(BLOCK_SLICER_METADATA, 1, meta_params, ini([("layer_height", "0.2")] * 50),
                 checksum)
    # G-code blocks of whole lines, about block_bytes of text each.
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    chunk = []
    size = 0

    def flush():
        nonlocal chunk, size
        if not chunk:
            return
        src = "\n".join(chunk) + "\n"
        if enc == 0:
            data = src.encode("latin-1")
        else:
            data = meatpack_encode(src, keep_comments=(enc == 2))
        out.extend(block(BLOCK_GCODE, comp, struct.pack("<H", enc), data, checksum))
        chunk, size = [], 0

    for line in lines:
        if size + len(line) + 1 > block_bytes:
            flush()
        chunk.append(line)
        size += len(line) + 1
    flush()

    expected = []
    for line in lines:
        e = expected_line(line, encoding)
        if e is not None:
            expected.append(e + "\n")
    expected += [f"; {k} = {v}\n" for k, v in print_metadata]
    return bytes(out), "".join(expected)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("input")
    p.add_argument("output", nargs="?")
    p.add_argument("--compression", default="hs12", choices=COMPRESSIONS)
    p.add_argument("--encoding", default="meatpack-comments", choices=ENCODINGS)
    p.add_argument("--checksum", default="crc32", choices=("crc32", "none"))
    p.add_argument("--block-bytes", type=int, default=65535)
    p.add_argument("--expected", help="write the text a reader must give back here")
    p.add_argument("--lines", type=int, default=0, help="only the first N lines of IN")
    p.add_argument("--fixtures", metavar="DIR",
                   help="write IN's every compression x encoding to DIR (NAME_COMP_ENC.bgcode "
                        "and .expected.gcode)")
    a = p.parse_args(argv)
    with open(a.input, encoding="latin-1", newline="") as f:
        text = f.read()
    if a.lines > 0:
        text = "".join(text.splitlines(keepends=True)[:a.lines])
    if a.fixtures:
        os.makedirs(a.fixtures, exist_ok=True)
        stem = os.path.splitext(os.path.basename(a.input))[0]
        with open(os.path.join(a.fixtures, stem + ".gcode"), "w", encoding="latin-1",
                  newline="") as f:
            f.write(text)
        for comp in COMPRESSIONS:
            for enc in ENCODINGS:
                data, expected = write_bgcode(text, comp, enc, True, a.block_bytes,
                                              metadata_compression=comp)
                base = os.path.join(a.fixtures, f"{stem}_{comp}_{enc}")
                with open(base + ".bgcode", "wb") as f:
                    f.write(data)
                with open(base + ".expected.gcode", "w", encoding="latin-1", newline="") as f:
                    f.write(expected)
        return 0
    if not a.output:
        p.error("give OUT.bgcode (or --fixtures DIR)")
    data, expected = write_bgcode(text, a.compression, a.encoding, a.checksum == "crc32",
                                  a.block_bytes)
    with open(a.output, "wb") as f:
        f.write(data)
    if a.expected:
        with open(a.expected, "w", encoding="latin-1", newline="") as f:
            f.write(expected)
    return 0


if __name__ == "__main__":
    sys.exit(main())
