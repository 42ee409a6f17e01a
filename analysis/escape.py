"""Strings from files (record fields, machine.json, folder names) put into markdown as text, never as markup (issue
33): `md` turns HTML's & < > into entities and escapes with a backslash every other character markdown gives a
meaning to inside a line (emphasis, code, links, images, headings, table cells, strikethrough, backslash); a line
break becomes a space, so a value never starts a line of its own (a heading, a list) nor ends a table row; a Unicode
control or format character (a bidirectional override such as U+202E, a zero-width joiner) is written as its name,
"U+202E", so that no value reorders or hides the text around it (issue 48).
`md_table` writes a frame as a markdown table with every cell and header escaped. (The analysis writes no HTML.)"""
import math
import unicodedata

# CommonMark lets a backslash escape any ASCII punctuation; these are the ones that start markup inside a line
# (links and images need [ and ], so parentheses stay as they are; < and > are entities).
_MD_SPECIAL = set("\\`*_[]#!|~")
_ENTITIES = {"&": "&amp;", "<": "&lt;", ">": "&gt;"}


def md(value):
    """`value` as markdown text that renders as exactly str(value)."""
    out = []
    for ch in str(value):
        if ch in _ENTITIES:
            out.append(_ENTITIES[ch])
        elif ch in _MD_SPECIAL:
            out.append("\\" + ch)
        elif ch in "\r\n\t\f\v":
            out.append(" ")
        elif unicodedata.category(ch) in ("Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp"):
            out.append(f"U+{ord(ch):04X}")
        else:
            out.append(ch)
    return "".join(out)


def _cell(v, floatfmt):
    if isinstance(v, bool) or v is None:
        return "—" if v is None else str(v)
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        if isinstance(v, float) and math.isnan(v):
            return "—"
        return format(v, floatfmt) if isinstance(v, float) else str(v)
    try:
        if v != v:  # pandas NA and numpy NaN
            return "—"
    except (TypeError, ValueError):
        pass
    if hasattr(v, "item") and not isinstance(v, str):  # numpy scalars
        return _cell(v.item(), floatfmt)
    return md(v)


def md_table(df, floatfmt=".4g"):
    """A frame as a GitHub markdown table: numbers formatted (NaN as —), every string escaped by md."""
    if df is None or len(df.columns) == 0:
        return "(no rows)"
    head = "| " + " | ".join(md(c) for c in df.columns) + " |"
    rule = "|" + "|".join("---:" if df[c].dtype.kind in "iuf" else "---" for c in df.columns) + "|"
    rows = ["| " + " | ".join(_cell(v, floatfmt) for v in r) + " |" for r in df.itertuples(index=False, name=None)]
    return "\n".join([head, rule, *rows])
