#!/usr/bin/env python3
"""RRV's teapot primitive as the Wavefront OBJ file our scene loader reads (radiosity/scene/obj_mesh.hpp).

    radiosity/scenes/rrv/teapot_obj.py TeapotEntityDef.cpp teapot.obj

The input is RRV's src/TeapotEntityDef.cpp: `Vertex TeapotEntity::teapot_v[1976]` (x, y, z) and
`int TeapotEntity::teapot_t[3752][3]` (0-based vertex indices). RRV's TeapotEntity::polygonize takes, for triangle i,
the vertices teapot_v[teapot_t[i][2 - j]], j = 0, 1, 2 (reversed order) and swaps y and z of each; the OBJ file holds
that mesh (1-based indices), the numbers written as RRV's source spells them. The output is written to a temporary
file beside it and renamed, so a failed conversion leaves nothing. Standard library only."""
import os
import re
import sys
import tempfile

NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def array_body(text, declaration):
    m = re.search(re.escape(declaration) + r"\s*=\s*\{(.*?)\n\};", text, re.S)
    if not m:
        raise ValueError(f"no array '{declaration}' in the input")
    return m.group(1)


def convert(text):
    """(vertices as (x, y, z) strings, faces as 0-based index triples) of RRV's source, checked against the sizes
    its declarations state."""
    verts = re.findall(rf"Vertex\(\s*({NUM})\s*,\s*({NUM})\s*,\s*({NUM})\s*\)",
                       array_body(text, "const Vertex TeapotEntity::teapot_v[1976]"))
    faces = [tuple(int(i) for i in t) for t in
             re.findall(r"\{\s*(\d+)\s*,\s*(\d+)\s*,\s*(\d+)\s*\}", array_body(text, "const int TeapotEntity::teapot_t[3752][3]"))]
    if len(verts) != 1976 or len(faces) != 3752:
        raise ValueError(f"expected 1976 vertices and 3752 triangles, found {len(verts)} and {len(faces)}")
    if any(not 0 <= i < len(verts) for f in faces for i in f):
        raise ValueError("a triangle names a vertex outside teapot_v")
    return verts, faces


def obj_text(verts, faces):
    lines = [f"# RRV 'teapot' primitive: {len(verts)} vertices, {len(faces)} triangles, in the primitive's own frame",
             "# (source data's y and z swapped and each face's vertex order reversed, as RRV applies them).",
             "# Data from RRV (Radiosity Renderer and Visualizer), GPL-3.0-or-later; see COPYING beside this file."]
    lines += [f"v {x} {z} {y}" for x, y, z in verts]
    lines += [f"f {c + 1} {b + 1} {a + 1}" for a, b, c in faces]
    return "\n".join(lines) + "\n"


def main(argv):
    if argv[:1] in (["-h"], ["--help"]):
        print(__doc__)
        return 0
    if len(argv) != 2:
        print("usage: teapot_obj.py TeapotEntityDef.cpp teapot.obj", file=sys.stderr)
        return 2
    src, out = argv
    try:
        with open(src, encoding="utf-8") as f:
            text = obj_text(*convert(f.read()))
    except (OSError, ValueError) as e:
        print(f"teapot_obj: {src}: {e}", file=sys.stderr)
        return 1
    fd, tmp = tempfile.mkstemp(prefix=".teapot-", suffix=".tmp", dir=os.path.dirname(os.path.abspath(out)))
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.chmod(tmp, 0o644)
        os.replace(tmp, out)
    except BaseException:
        os.unlink(tmp)
        raise
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
