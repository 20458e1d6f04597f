#!/usr/bin/env python3
"""Writes 3MF archives with Python's zipfile, independently of amctl's reader (libzip), in the
layout OrcaSlicer and Bambu Studio give a sliced project (.gcode.3mf): [Content_Types].xml,
_rels/.rels, 3D/3dmodel.model, Metadata/plate_N.gcode (+ .md5), Metadata/plate_N.png,
Metadata/slice_info.config.

    make_3mf.py OUT.gcode.3mf PLATE1.gcode [PLATE2.gcode ...]   a sliced project
    make_3mf.py OUT.3mf --model                                  a model only (no G-code)
    make_3mf.py OUT.gcode.3mf --bomb MEBIBYTES                   one plate of that many MiB of
                                                                 zeros (deflates ~1000:1)
"""
import hashlib
import io
import sys
import zipfile

CONTENT_TYPES = ('<?xml version="1.0" encoding="UTF-8"?>\n'
                 '<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">'
                 '<Default Extension="rels" ContentType="application/vnd.openxmlformats-package.'
                 'relationships+xml"/><Default Extension="model" ContentType="application/'
                 'vnd.ms-package.3dmanufacturing-3dmodel+xml"/><Default Extension="png" '
                 'ContentType="image/png"/><Default Extension="gcode" ContentType="text/x.gcode"/>'
                 '</Types>\n')
RELS = ('<?xml version="1.0" encoding="UTF-8"?>\n<Relationships xmlns="http://schemas.'
        'openxmlformats.org/package/2006/relationships"><Relationship Target="/3D/3dmodel.model" '
        'Id="rel-1" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>'
        '</Relationships>\n')
MODEL = ('<?xml version="1.0" encoding="UTF-8"?>\n<model unit="millimeter" xml:lang="en-US" '
         'xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02"><resources>'
         '<object id="1" type="model"><mesh><vertices><vertex x="0" y="0" z="0"/>'
         '<vertex x="10" y="0" z="0"/><vertex x="0" y="10" z="0"/><vertex x="0" y="0" z="10"/>'
         '</vertices><triangles><triangle v1="0" v2="2" v3="1"/><triangle v1="0" v2="1" v3="3"/>'
         '<triangle v1="1" v2="2" v3="3"/><triangle v1="0" v2="3" v3="2"/></triangles></mesh>'
         '</object></resources><build><item objectid="1"/></build></model>\n')


def sliced_3mf(plates):
    """plates: list of G-code texts (bytes). Returns the archive's bytes."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("[Content_Types].xml", CONTENT_TYPES)
        z.writestr("_rels/.rels", RELS)
        z.writestr("3D/3dmodel.model", MODEL)
        info = "".join(f'<plate><metadata key="index" value="{i}"/></plate>'
                       for i in range(1, len(plates) + 1))
        z.writestr("Metadata/slice_info.config", f"<config>{info}</config>\n")
        for i, g in enumerate(plates, start=1):
            z.writestr(f"Metadata/plate_{i}.gcode", g)
            z.writestr(f"Metadata/plate_{i}.gcode.md5", hashlib.md5(g).hexdigest().upper())
            z.writestr(f"Metadata/plate_{i}.png", b"\x89PNG\r\n\x1a\n" + bytes(64))
    return buf.getvalue()


def model_3mf():
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("[Content_Types].xml", CONTENT_TYPES)
        z.writestr("_rels/.rels", RELS)
        z.writestr("3D/3dmodel.model", MODEL)
    return buf.getvalue()


def bomb_3mf(mebibytes):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("Metadata/plate_1.gcode", bytes(mebibytes << 20))
    return buf.getvalue()


def main(argv):
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    out = argv[0]
    if argv[1] == "--model":
        data = model_3mf()
    elif argv[1] == "--bomb":
        data = bomb_3mf(int(argv[2]))
    else:
        plates = []
        for p in argv[1:]:
            with open(p, "rb") as f:
                plates.append(f.read())
        data = sliced_3mf(plates)
    with open(out, "wb") as f:
        f.write(data)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
