"""Strings from records, machine.json and folder names reach the reports as text, never as markdown or HTML (issue
33): a report made from records whose fields hold every markdown and HTML special character shows those characters
as text; one machine's unreadable machine.json leaves that machine out of MACHINES.md, named, and the others in."""
import html
import json
import re
import shutil
import string
import sys

from conftest import ROOT, run

sys.path.insert(0, str(ROOT))
from analysis.escape import md  # noqa: E402

REF = (ROOT / "results" / "REFERENCE").read_text().strip()
HOSTILE = ("<script>alert(1)</script> <img src=x onerror=alert(2)> [l](javascript:alert(3)) ![i](x.png) "
           "<a href='javascript:alert(4)'>a</a> # h | c || *em* _em_ `code` ~~s~~ &amp; &lt; \\ \\| -->\n## heading")
EVERY = string.punctuation + " \t\r\n" + HOSTILE


def shown(text):
    """What a CommonMark renderer shows for inline text made of plain characters, backslash escapes of ASCII
    punctuation and entities (the only constructs md() writes)."""
    out, i = [], 0
    while i < len(text):
        if text[i] == "\\" and i + 1 < len(text) and text[i + 1] in string.punctuation:
            out.append(text[i + 1])
            i += 2
        elif text[i] == "&":
            m = re.match(r"&(amp|lt|gt);", text[i:])
            assert m, f"a raw & that could start an entity at {i} of {text!r}"
            out.append(html.unescape(m.group(0)))
            i += len(m.group(0))
        else:
            assert text[i] not in "<>`*_[]|#~!\n", f"unescaped {text[i]!r} at {i} of {text!r}"
            out.append(text[i])
            i += 1
    return "".join(out)


def test_md_renders_every_special_character_as_text():
    assert shown(md(EVERY)) == re.sub(r"[\t\r\n]", " ", EVERY)
    assert "\n" not in md(EVERY) and "<" not in md(EVERY)


def fixture(tmp_path):
    res = tmp_path / "results"
    lines = (ROOT / "results" / REF / "table42" / "quick.jsonl").read_text().splitlines()[:6]
    recs = []
    for line in lines:
        r = json.loads(line)
        for k in ("host", "cpu_model", "compiler"):
            r["provenance"][k] = HOSTILE
        r["provenance"]["git_dirty"] = False
        recs.append(json.dumps(r))
    (res / "good" / "table42").mkdir(parents=True)
    (res / "good" / "table42" / "ci.jsonl").write_text("\n".join(recs) + "\n")
    (res / "good" / "table43").mkdir()
    (res / "good" / "table43" / "ci.skipped").write_text(json.dumps(
        {"case": "ci/table43/0/x", "host": HOSTILE, "utc": "2026-01-01T00:00:00Z", "reason": HOSTILE}) + "\n")
    (res / "good" / "machine.json").write_text(json.dumps({"label": "good", "host": HOSTILE, "cpu_model": HOSTILE,
                                                           "cpus_online": 2}))
    bad = res / "x<img src=y onerror=alert(5)>#|"
    (bad / "table42").mkdir(parents=True)
    (bad / "machine.json").write_text("{not json <script>")
    return res


def headings_and_tables_hold(text):
    """No line of the file is markup the hostile text made: every heading is one the generator writes, and every
    table row has as many unescaped | as its table's header."""
    cols = None
    for line in text.splitlines():
        assert "<script" not in line and "<img" not in line and "<a " not in line, line
        assert "alert" not in line or not re.search(r"(?<!\\)\]\(", line), line  # a link the text made
        if line.startswith("#"):
            assert "heading" not in line and "alert" not in line, line
        if line.startswith("|"):
            n = len(re.findall(r"(?<!\\)\|", line))
            cols = cols if cols is not None and not line.startswith("|---") or cols else n
            if not line.startswith("|---"):
                assert n == cols, line
        else:
            cols = None


def test_report_from_hostile_records_shows_them_as_text(tmp_path):
    res = fixture(tmp_path)
    env = {"RESULTS": str(res)}
    p = run([sys.executable, "-m", "analysis", "tables", "ci", "--machine", "good"], env=env, cwd=ROOT, timeout=300)
    assert p.returncode == 0, p.stderr
    p = run([sys.executable, "-m", "analysis", "report", "ci", "--machine", "good"], env=env, cwd=ROOT, timeout=300)
    assert p.returncode == 0, p.stderr
    p = run([sys.executable, "-m", "analysis", "machines", "ci"], env=env, cwd=ROOT, timeout=300)
    assert p.returncode == 0, p.stderr
    # the unreadable machine.json is named on stderr and in MACHINES.md; the good machine is still there
    assert "onerror=alert(5)" in p.stderr and "machine.json" in p.stderr
    report = (res / "report" / "good" / "REPORT-ci.md").read_text()
    machines = (res / "report" / "MACHINES.md").read_text()
    assert "| good " in machines and "left out" in machines
    flat = md(HOSTILE)
    assert flat in report and flat in machines
    assert shown(flat) == HOSTILE.replace("\n", " ")
    for text in (report, machines, (res / "good" / "tables" / "table42_ci.md").read_text()):
        headings_and_tables_hold(text)
