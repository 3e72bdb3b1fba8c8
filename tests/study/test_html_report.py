"""``study report --html``: one self-contained page with every figure and table of the report,
the per-trial table and the replays found in the run directory (issue 33, Deliver 3)."""

from __future__ import annotations

import base64
import re
from html.parser import HTMLParser

import pytest

from offroadbench.cli import study as cli_study
from offroadbench.study import load, run_study, study_from_dict
from offroadbench.study.report.html import markdown_to_html, replay_anchor
from offroadbench.study.spec.config import plan_cells

from tests.study.test_run import STUDY, fake_trials

#: the smallest valid GIF (1 x 1, one colour)
GIF = base64.b64decode("R0lGODlhAQABAIAAAP///wAAACH5BAEAAAAALAAAAAABAAEAAAICRAEAOw==")


class Page(HTMLParser):
    """Collects images (src, data-name), tables (header, row count), anchors and ids."""

    def __init__(self):
        super().__init__()
        self.images, self.tables, self.links, self.ids, self.scripts = [], [], [], set(), 0
        self._table = None
        self._in_th = False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.add(a["id"])
        if tag == "img":
            self.images.append(a)
        elif tag == "table":
            self._table = {"class": a.get("class", ""), "header": [], "rows": 0}
        elif tag == "th" and self._table is not None:
            self._in_th = True
            self._table["header"].append("")
        elif tag == "tr" and self._table is not None:
            self._table["rows"] += 1
        elif tag == "a":
            self.links.append(a.get("href", ""))
        elif tag == "script":
            self.scripts += 1
            assert "src" not in a  # inline only

    def handle_endtag(self, tag):
        if tag == "th":
            self._in_th = False
        elif tag == "table" and self._table is not None:
            self.tables.append(self._table)
            self._table = None

    def handle_data(self, data):
        if self._in_th:
            self._table["header"][-1] += data


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    study = study_from_dict(STUDY)
    run = tmp_path_factory.mktemp("html") / "run"
    run_study(study, plan_cells(study), run, executor="inline", trial_fn=fake_trials)
    return run


def test_the_html_report_holds_every_figure_and_table_of_the_markdown(run):
    trials = load(run)
    failed = trials[~trials["success"].astype(bool)]
    assert len(failed) >= 1  # the fake physics fails some steep missions
    f = failed.iloc[0]
    (run / "replays").mkdir()
    (run / "replays" / f"cell{f.cell}_terrain{f.terrain}_mission{f.mission}.gif").write_bytes(GIF)

    out = run / "report"
    path = cli_study.write_report(run, out, html=True)
    assert path == out / "report.html"
    md = (out / "report.md").read_text()
    page = Page()
    page.feed(path.read_text(encoding="utf-8"))

    # every figure of the Markdown is inline, as a PNG data URI that decodes to the same figure file
    md_figures = re.findall(r"^!\[[^\]]*\]\(([^)]+)\)$", md, flags=re.M)
    assert md_figures and set(md_figures) <= {p.name for p in out.glob("*.png")}
    inline = {img["data-name"]: img["src"] for img in page.images if "data-name" in img}
    assert set(inline) == set(md_figures)
    for src in inline.values():
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"

    # every Markdown table is an HTML table with the same header and row count
    md_tables = re.findall(r"((?:^\|.*\|\n)+)", md, flags=re.M)
    sortable = [t for t in page.tables if "sortable" in t["class"] and "trials" not in t["class"]]
    assert len(sortable) == len(md_tables)
    for text, tab in zip(md_tables, sortable, strict=True):
        rows = text.strip().splitlines()
        header = [c.strip().replace("`", "") for c in rows[0].strip().strip("|").split("|")]
        assert [h.strip() for h in tab["header"]] == header
        assert tab["rows"] == len(rows) - 1  # header row + body rows (the rule line is not a row)

    # the per-trial table: one row per trial; the failure with a replay links to it, inline
    per_trial = [t for t in page.tables if "trials" in t["class"]]
    assert len(per_trial) == 1 and per_trial[0]["rows"] == len(trials) + 1
    anchor = replay_anchor(int(f.cell), int(f.terrain), int(f.mission))
    assert f"#{anchor}" in page.links and anchor in page.ids
    gifs = [img for img in page.images if img.get("data-kind") == "gif"]
    assert len(gifs) == 1 and base64.b64decode(gifs[0]["src"].split(",", 1)[1]) == GIF
    assert page.scripts == 1
    assert not [img for img in page.images if not img["src"].startswith("data:")]  # nothing outside the file


def test_markdown_subset():
    html = markdown_to_html("# T\n\nsome `x<1` and **bold**\n\n- a\n- b\n\n| a | b |\n|---|---|\n| 1 | 2 |\n\n![F](f.png)\n",
                            {"f.png": "data:image/png;base64,AA=="})
    assert '<h1 id="t">T</h1>' in html
    assert "<code>x&lt;1</code>" in html and "<strong>bold</strong>" in html
    assert "<ul><li>a</li><li>b</li></ul>" in html
    assert "<th>a</th><th>b</th>" in html and '<td class="num">1</td><td class="num">2</td>' in html
    assert 'src="data:image/png;base64,AA=="' in html


#: link payloads a study description could carry into a page meant to be shared (issue 44)
PAYLOADS = [
    "[a](javascript:alert%281%29)",
    "[b](JaVaScRiPt:alert(1))",
    "[c](&#106;avascript:alert(1))",  # entity-encoded
    "[d](&#x6A;&#x61;vascript:alert(1))",
    "[e](data:text/html;base64,PHNjcmlwdD5hbGVydCgxKTwvc2NyaXB0Pg==)",
    "[f](vbscript:msgbox(1))",
    "[g](VBScript:msgbox(1))",
    "[h](<java\tscript:alert(1)>)",  # a browser drops the tab
    "[i](java%09script:alert(1))",
    "[j](file:///etc/passwd)",
    "[k][ref]\n\n[ref]: javascript:alert(1)",
    "<javascript:alert(1)>",
    "![l](javascript:alert(1))",
    '<a href="javascript:alert(1)">m</a>',
]
SAFE = ["[ok1](https://example.org/a?b=1#c)", "[ok2](http://example.org)", "[ok3](report.md)", "[ok4](#replays)",
        "[ok5](../other/report.html)"]


class Targets(HTMLParser):
    """Every URL attribute of a page."""

    def __init__(self):
        super().__init__()
        self.urls = []

    def handle_starttag(self, tag, attrs):
        self.urls += [v for k, v in attrs if k in ("href", "src", "action", "formaction", "srcset") and v is not None]


@pytest.mark.parametrize("payload", PAYLOADS)
def test_a_link_to_an_unsafe_scheme_is_inert(payload):
    from offroadbench.study.report.html import safe_url

    page = markdown_to_html(f"# Study\n\nSee {payload} here.\n", {})
    parser = Targets()
    parser.feed(page)
    assert parser.urls == [] or all(safe_url(u) and not u.startswith("data:") for u in parser.urls), page
    for word in ("javascript:", "vbscript:", "data:text", "file:"):
        assert f'href="{word}' not in page.lower() and f'src="{word}' not in page.lower(), page
    assert "<script" not in page.lower()


def test_safe_links_stay_links():
    page = markdown_to_html("\n\n".join(SAFE), {})
    parser = Targets()
    parser.feed(page)
    assert parser.urls == ["https://example.org/a?b=1#c", "http://example.org", "report.md", "#replays",
                           "../other/report.html"]


def test_safe_url_rules():
    from offroadbench.study.report.html import safe_url

    for url in ("https://x.org", "HTTP://x.org", "a/b.png", "#f", "?q=1", "", "./a:b", "a/b:c"):
        assert safe_url(url), url
    for url in ("javascript:x", " javascript:x", "jav\nascript:x", "\x01javascript:x", "data:image/png;base64,AA",
                "vbscript:x", "mailto:a@b.c", "ftp://x", "java%09script:x", "a:b"):
        assert not safe_url(url), url


def test_report_html_of_a_study_whose_description_links_to_javascript(tmp_path):
    """The issue's case end to end: the description's links are in report.md, none live in report.html."""
    import copy

    data = copy.deepcopy(STUDY)
    data["study"]["description"] = "Read " + " and ".join(p.replace("\n", " ") for p in PAYLOADS[:7]) + "."
    study = study_from_dict(data)
    run = tmp_path / "run"
    run_study(study, plan_cells(study), run, executor="inline", trial_fn=fake_trials)
    path = cli_study.write_report(run, run / "report", html=True)
    assert "javascript:alert%281%29" in (run / "report" / "report.md").read_text()
    page = path.read_text(encoding="utf-8")
    assert "javascript:alert" in page  # the text is kept, as text
    assert 'href="javascript:' not in page.lower() and 'href="vbscript:' not in page.lower()
    assert 'href="data:' not in page.lower()
