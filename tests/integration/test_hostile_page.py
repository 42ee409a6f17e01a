"""Strings from a scene reach the web page and the terminal as text only (issue 33, problem 1): a scene whose every
name (and its file name) is an injection string gives a page that, in headless Chromium, shows the names as text,
runs none of them, sends no request and prints nothing to the console; `bin/radiosity info` and the one-line errors
show control, C1 and bidirectional characters escaped."""
import html.parser
import re
from xml.sax.saxutils import quoteattr

import pytest

from conftest import BIN, run
from test_relight import chromium, requires_chromium

# Each would run script, load something or break out of its element if it reached the page as HTML.
INJECTIONS = [
    "<svg/onload=\"document.title='PWNED-svg'\">",
    "</script><script>document.title='PWNED-close'</script>",
    "<!--<script>",
    "\"><iframe srcdoc=\"<script>parent.document.title='PWNED-iframe'</script>\">",
    "<img src=\"http://127.0.0.1:9/leak.png\">",
    "<style>*{background:url(http://127.0.0.1:9/css)}</style>",
    "<a href=\"javascript:document.title='PWNED-href'\" id=\"pwn\">x</a>",
    "@DATA@ @TITLE@ &amp; \u2028\u2029 ' \"",
]
FILE_NAME = "t\"><img src=x onerror=\"document.title='PWNED-file'\">.xml"


def scene_xml(names):
    """One emitting triangle per name (each a light of the page), over a floor."""
    defs, body = [], []
    for k, name in enumerate(names):
        y = 1 + 0.1 * k
        defs.append(f'<objectdef name={quoteattr(name)}><triangleset name="t" emission="1,1,1" reflectivity=".3,.3,.3">'
                    f'<triangle><vertex x="0" y="{y}" z="0"/><vertex x="1" y="{y}" z="0"/><vertex x="0" y="{y}" '
                    f'z="1"/></triangle></triangleset></objectdef>')
        body.append(f"<object name={quoteattr(name)}/>")
    floor = ('<objectdef name="floor"><triangleset name="f" emission="0,0,0" reflectivity=".5,.5,.5"><triangle>'
             '<vertex x="0" y="0" z="0"/><vertex x="0" y="0" z="1"/><vertex x="1" y="0" z="0"/></triangle>'
             '</triangleset></objectdef>')
    return f"<scene><head>{''.join(defs)}{floor}</head><body>{''.join(body)}<object name=\"floor\"/></body></scene>"


class LightLabels(html.parser.HTMLParser):
    """The text of each light's label: the first <div> inside each <div class="light">."""

    def __init__(self):
        super().__init__()
        self.labels, self.depth, self.in_label, self.tags = [], 0, False, []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        if tag == "div" and ("class", "light") in attrs:
            self.depth = len(self.tags)
        elif tag == "div" and self.depth and len(self.tags) == self.depth + 1:
            self.in_label = True
            self.labels.append("")

    def handle_endtag(self, tag):
        while self.tags and self.tags.pop() != tag:
            pass
        if len(self.tags) < self.depth:
            self.depth = 0
        self.in_label = False

    def handle_data(self, data):
        if self.in_label:
            self.labels[-1] += data


@pytest.fixture(scope="module")
def hostile_page(tmp_path_factory):
    d = tmp_path_factory.mktemp("hostile-page")
    scene = d / FILE_NAME
    scene.write_text(scene_xml(INJECTIONS), encoding="utf-8")
    assert run([BIN / "radiosity", "formfactors", scene, "-o", d / "s.ff", "--hemicube", "16", "--quiet"]).returncode == 0
    p = run([BIN / "radiosity", "web", scene, "--ff", d / "s.ff", "-o", d / "page.html", "--quiet"])
    assert p.returncode == 0, p.stderr
    return d, d / "page.html"


def test_the_page_holds_no_scene_string_as_markup_and_its_csp_runs_no_inline_script(hostile_page):
    _, page = hostile_page
    text = page.read_text(encoding="utf-8")
    csp = re.search(r'http-equiv="Content-Security-Policy" content="([^"]*)"', text).group(1)
    assert "unsafe-inline" not in csp and "unsafe-hashes" not in csp and "script-src 'sha256-" in csp, csp
    assert "require-trusted-types-for 'script'" in csp and "base-uri 'none'" in csp
    program = text.rsplit("<script>", 1)[1]
    assert not re.search(r"innerHTML|outerHTML|insertAdjacentHTML|document\.write|\beval\(", program)
    # the page's markup: two scripts (the data and the program), one style, no element from a scene string
    assert len(re.findall(r"<script\b", text)) == 2 and len(re.findall(r"</script", text)) == 2
    assert not re.search(r"<(svg|img|iframe|a)\b", text) and "PWNED" in text  # the names are there, as text


@requires_chromium
def test_headless_chromium_shows_the_names_as_text_and_runs_none_of_them(hostile_page):
    d, page = hostile_page
    url = page.as_uri() + "?spin=0&" + "%3Cimg%20src%3Dx%20onerror%3Dalert(1)%3E=1,1,1,1"  # an unknown light, too
    p, console, requests = chromium(url, "--dump-dom", cwd=d)
    assert p.returncode == 0, p.stderr[-2000:]
    assert console == [] and requests == [], (console, requests)
    dom = p.stdout
    title = re.search(r"<title>(.*?)</title>", dom, re.S).group(1)
    assert "PWNED" not in title.replace("PWNED-file", "") and "Relight t" in title  # no script set document.title
    markup = dom.split("<script", 1)[0] + dom.rsplit("</script>", 1)[-1]
    assert not re.search(r"<(svg|img|iframe|a)\b", markup) and len(re.findall(r"<style\b", markup)) == 1, markup
    labels = LightLabels()
    labels.feed(dom)
    assert labels.labels == [n + ".1" for n in INJECTIONS], labels.labels
    assert "unknown light &lt;img src=x onerror=alert(1)&gt;" in dom  # the URL's name shown as text too


def test_info_and_errors_show_control_characters_escaped(tmp_path):
    name = "lamp\x1b]0;PWN\x07\u009b31m\u202eevil"
    xml = scene_xml([name]).replace("\x1b", "&#27;").replace("\x07", "&#7;")
    (tmp_path / "esc.xml").write_text(xml, encoding="utf-8")
    p = run([BIN / "radiosity", "info", tmp_path / "esc.xml"])
    assert p.returncode == 0, p.stderr
    out = p.stdout
    assert "lamp\\x1b]0;PWN\\x07\\u009b31m\\u202eevil.1" in out, out
    assert not re.search("[\x00-\x09\x0b-\x1f\x7f\u0080-\u009f\u202a-\u202e\u2066-\u2069]", out), repr(out)
    # a frame naming an unknown light lists the scene's lights in the one-line error: escaped as well
    assert run([BIN / "radiosity", "formfactors", tmp_path / "esc.xml", "-o", tmp_path / "e.ff", "--hemicube", "8",
                "--quiet"]).returncode == 0
    (tmp_path / "f.json").write_text('{"frames": [{"lights": {"no\\u001b[2J": {"intensity": 1}}}]}')
    p = run([BIN / "radiosity", "relight", tmp_path / "esc.xml", "--ff", tmp_path / "e.ff", "--frames",
             tmp_path / "f.json", "--quiet"])
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert "no\\x1b[2J" in p.stderr and "lamp\\x1b]0;PWN" in p.stderr, repr(p.stderr)
    assert not re.search("[\x00-\x09\x0b-\x1f\x7f\u0080-\u009f\u202a-\u202e]", p.stderr), repr(p.stderr)
