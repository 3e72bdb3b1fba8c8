"""A study report as one self-contained HTML file (``offroadbench study report RUN_DIR --html``).

The HTML carries the same content as ``report.md`` (:func:`offroadbench.study.report.markdown.build_report`):
the "what ran" header, every table and every figure, plus

* the per-trial table (one row per stored trial, every column sortable by a click on its header,
  a few lines of inline JavaScript, no library);
* the replay animations and figures found in the run directory (``RUN_DIR/replays/`` and the run
  directory itself, files named ``cell<C>_terrain<T>_mission<M>.gif|.mp4|.png`` as ``study replay``
  writes them by default), inline, each with an anchor; a failed trial in the per-trial table links
  to its replay where one exists and shows the command that makes one otherwise.

Everything is inline (figures and animations as base64 ``data:`` URIs, the style sheet and the
script in the page), so the file can be mailed or archived alone. The Markdown of the report is
rendered by markdown-it-py (CommonMark with GFM tables; raw HTML escaped), and since the page is
meant to be shared, a link keeps its ``href`` only for ``http``, ``https``, relative and fragment
targets (:func:`safe_url`): a study description's ``[x](javascript:...)`` stays inert text.
"""

from __future__ import annotations

import base64
import html
import io
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import pandas as pd

__all__ = ["SAFE_SCHEMES", "ReplayMedia", "find_replays", "figure_png", "markdown_to_html", "safe_url", "trial_table_html",
           "build_html", "report_html"]

#: a replay file written by ``study replay`` under its default name
_REPLAY_NAME = re.compile(r"^cell(\d+)_terrain(\d+)_mission(\d+)\.(gif|mp4|png)$")
_MIME = {"gif": "image/gif", "mp4": "video/mp4", "png": "image/png"}


@dataclass(frozen=True)
class ReplayMedia:
    """One replay file of trial (cell, terrain, mission): its kind (gif, mp4, png) and bytes."""

    cell: int
    terrain: int
    mission: int
    kind: str
    data: bytes

    @property
    def key(self) -> tuple[int, int, int]:
        return (self.cell, self.terrain, self.mission)


def replay_anchor(cell: int, terrain: int, mission: int) -> str:
    """The HTML id of a trial's replay section."""
    return f"replay-c{cell}-t{terrain}-m{mission}"


def find_replays(folders: Sequence[str | Path], max_bytes: int = 40_000_000) -> list[ReplayMedia]:
    """The replay figures and animations in ``folders`` (not recursive), sorted by trial and kind;
    files over ``max_bytes`` in all are left out (the report stays a mailable size)."""
    out: list[ReplayMedia] = []
    seen: set[tuple[int, int, int, str]] = set()
    total = 0
    for folder in folders:
        d = Path(folder)
        if not d.is_dir():
            continue
        for p in sorted(d.iterdir()):
            m = _REPLAY_NAME.match(p.name)
            if not m or not p.is_file():
                continue
            cell, terrain, mission, kind = int(m[1]), int(m[2]), int(m[3]), m[4]
            if (cell, terrain, mission, kind) in seen:
                continue
            size = p.stat().st_size
            if total + size > max_bytes:
                continue
            total += size
            seen.add((cell, terrain, mission, kind))
            out.append(ReplayMedia(cell, terrain, mission, kind, p.read_bytes()))
    order = {"gif": 0, "mp4": 1, "png": 2}
    return sorted(out, key=lambda r: (r.key, order[r.kind]))


def figure_png(fig: Any, dpi: int = 110) -> bytes:
    """A matplotlib Figure as PNG bytes (in memory)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def _data_uri(mime: str, data: bytes) -> str:
    return f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"


# ---------------------------------------------------------------------------- Markdown
#: the URL schemes a link of the page may have; relative URLs and fragments have none
SAFE_SCHEMES = ("http", "https")
_SCHEME = re.compile(r"^([a-zA-Z][a-zA-Z0-9+.-]*):")
_NUMBER = re.compile(r"^\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?\s*$|^\s*(nan|inf|-inf)\s*$")
_TAGS = re.compile(r"<[^>]+>")


def safe_url(url: str) -> bool:
    """Whether a link target may stay live in a page meant to be shared: ``http``, ``https``, a
    relative URL or a fragment. The test is on the URL as a browser reads it (ASCII whitespace and
    control characters dropped: ``java\tscript:`` is ``javascript:``), any letter case; a colon
    before the first ``/``, ``?`` or ``#`` names a scheme, and any other scheme is refused
    (``javascript:``, ``vbscript:``, ``data:``, ``file:`` ...)."""
    bare = re.sub(r"[\x00-\x20\x7f]", "", url)
    m = _SCHEME.match(bare)
    if m:
        return m[1].lower() in SAFE_SCHEMES
    head = re.split(r"[/?#]", bare, maxsplit=1)[0]
    return ":" not in head


def _renderer():
    """markdown-it-py (CommonMark with GFM tables; raw HTML in the Markdown is escaped, not
    passed through) whose links and images keep only :func:`safe_url` targets: any other is
    left as the Markdown text it was, with no ``href``."""
    from markdown_it import MarkdownIt

    md = MarkdownIt("commonmark", {"html": False, "linkify": False, "typographer": False}).enable("table")
    md.validateLink = safe_url  # called on every link, image and autolink target (entities decoded)
    rules = md.renderer.rules
    for kind, tag in (("bullet_list", "ul"), ("ordered_list", "ol")):
        rules[f"{kind}_open"] = lambda tokens, idx, options, env, tag=tag: f"<{tag}>"
        rules[f"{kind}_close"] = lambda tokens, idx, options, env, tag=tag: f"</{tag}>\n"
    rules["list_item_open"] = lambda tokens, idx, options, env: "<li>"
    rules["list_item_close"] = lambda tokens, idx, options, env: "</li>"
    return md


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")


def _figure(alt: str, name: str, images: Mapping[str, str]) -> str:
    src = images.get(name)
    if src is None:
        return f"<p>(figure {html.escape(name)} missing)</p>\n"
    return (f'<figure><img src="{src}" alt="{html.escape(alt, quote=True)}" data-name="{html.escape(name)}">'
            f"<figcaption>{html.escape(alt)} ({html.escape(name)})</figcaption></figure>\n")


def markdown_to_html(md: str, images: Mapping[str, str]) -> str:
    """HTML of the report's Markdown, rendered by markdown-it-py (:func:`_renderer`: links only to
    safe targets, :func:`safe_url`). A paragraph that is one image ``![alt](name)`` becomes a
    ``<figure>`` of ``images[name]`` (a data URI); a pipe table a sortable ``<table>`` whose
    numeric columns are right-aligned; a heading gets an ``id`` (its text, lower case, dashed)."""
    from markdown_it.token import Token

    renderer = _renderer()
    tokens = renderer.parse(md)
    out: list[Token] = []
    i = 0

    def raw(text: str) -> Token:
        token = Token("html_block", "", 0)
        token.content = text
        return token

    def inline(token: Token) -> str:
        return renderer.renderer.renderInline(token.children or [], renderer.options, {})

    while i < len(tokens):
        t = tokens[i]
        if t.type == "heading_open":
            t.attrSet("id", _slug(tokens[i + 1].content))
        elif (t.type == "paragraph_open" and tokens[i + 1].children and len(tokens[i + 1].children) == 1
              and tokens[i + 1].children[0].type == "image"):
            img = tokens[i + 1].children[0]
            out.append(raw(_figure(img.content, str(img.attrGet("src") or ""), images)))
            i += 3
            continue
        elif t.type == "table_open":
            header: list[str] = []
            rows: list[list[str]] = []
            while tokens[i].type != "table_close":
                tok = tokens[i]
                if tok.type == "tr_open":
                    rows.append([])
                elif tok.type == "thead_close":
                    header = rows.pop()
                elif tok.type == "inline":
                    rows[-1].append(inline(tok))
                i += 1
            out.append(raw(_table(header, rows) + "\n"))
            i += 1
            continue
        out.append(t)
        i += 1
    return renderer.renderer.render(out, renderer.options, {}).strip()


def _is_number(content: str) -> bool:
    return bool(_NUMBER.match(_TAGS.sub("", content)))


def _table(header: Sequence[str], rows: Sequence[Sequence[str]], cls: str = "sortable") -> str:
    """A sortable table of HTML cells. A column whose cells are all numbers (blanks aside) is
    right-aligned (class ``num``)."""
    th = "".join(f"<th>{h}</th>" for h in header)
    cells = [list(r) for r in rows]
    ncol = max((len(r) for r in cells), default=0)
    numeric = [any(j < len(r) and _TAGS.sub("", r[j]).strip() for r in cells)
               and all(j >= len(r) or not _TAGS.sub("", r[j]).strip() or _is_number(r[j]) for r in cells)
               for j in range(ncol)]
    body = ["<tr>" + "".join(f'<td class="num">{c}</td>' if numeric[j] else f"<td>{c}</td>" for j, c in enumerate(r))
            + "</tr>" for r in cells]
    return f'<table class="{cls}"><thead><tr>{th}</tr></thead><tbody>{"".join(body)}</tbody></table>'


# ---------------------------------------------------------------------------- per-trial table
#: the per-trial columns shown first (those present), then the grid axes
_TRIAL_COLUMNS = ("cell", "terrain", "mission", "success", "failure_reason", "sim_time_s",
                  "final_distance_to_goal_m", "path_length_m", "rms_pitch_rate_deg_s", "rms_roll_rate_deg_s",
                  "rms_vertical_accel_m_s2")


def _cell_text(v: Any) -> str:
    if isinstance(v, float):
        return "" if v != v else f"{v:.4g}"
    return html.escape(str(v))


def trial_table_html(trials: pd.DataFrame, replays: Sequence[ReplayMedia], run_dir: str,
                     grid_columns: Sequence[str] = ()) -> str:
    """The per-trial table: one row per trial, sortable; a failed trial links to its replay
    section (when one was found) or shows the command that writes one."""
    have = {r.key for r in replays}
    cols = [c for c in _TRIAL_COLUMNS if c in trials.columns]
    cols[3:3] = [c for c in grid_columns if c in trials.columns and c not in cols]
    if "dropped_contacts" in trials.columns and trials["dropped_contacts"].astype(float).notna().any():
        cols.append("dropped_contacts")  # MuJoCo Warp's false contacts, where recorded
    header = [*cols, "replay"]
    rows = []
    for rec in trials[cols].itertuples(index=False):
        row = dict(zip(cols, rec, strict=True))
        cells = [_cell_text(row[c]) for c in cols]
        key = (int(row.get("cell", -1)), int(row.get("terrain", -1)), int(row.get("mission", -1)))
        failed = "success" in row and not bool(row["success"])
        if key in have:
            cells.append(f'<a href="#{replay_anchor(*key)}">replay</a>')
        elif failed:
            cmd = (f"offroadbench study replay {run_dir} --cell {key[0]} --terrain {key[1]} --mission {key[2]} "
                   f"--animate {run_dir}/replays/cell{key[0]}_terrain{key[1]}_mission{key[2]}.gif")
            cells.append(f'<code class="cmd">{html.escape(cmd)}</code>')
        else:
            cells.append("")
        rows.append(cells)
    return _table([html.escape(h) for h in header], rows, cls="sortable trials")


def _replays_html(replays: Sequence[ReplayMedia]) -> str:
    if not replays:
        return ("<p>No replay animations in the run directory. A failed trial's row in the table above "
                "gives the command that writes one (<code>study replay ... --animate</code>); the next "
                "<code>study report --html</code> puts it here.</p>")
    out, current = [], None
    for r in replays:
        if r.key != current:
            if current is not None:
                out.append("</section>")
            current = r.key
            c, t, m = r.key
            out.append(f'<section class="replay" id="{replay_anchor(c, t, m)}"><h3>cell {c}, terrain {t}, mission {m}</h3>')
        uri = _data_uri(_MIME[r.kind], r.data)
        if r.kind == "mp4":
            out.append(f'<video controls loop src="{uri}" data-kind="mp4"></video>')
        else:
            out.append(f'<img src="{uri}" alt="replay {r.kind}" data-kind="{r.kind}">')
    out.append("</section>")
    return "\n".join(out)


_STYLE = """
body{font-family:system-ui,sans-serif;max-width:1300px;margin:1em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:.5em 0 1.2em;font-size:13px}
th,td{border:1px solid #ccc;padding:2px 6px;text-align:left}
td.num{text-align:right;font-variant-numeric:tabular-nums}
th{background:#eee;cursor:pointer;user-select:none;position:sticky;top:0}
th.asc::after{content:" \\25B2"} th.desc::after{content:" \\25BC"}
figure{margin:.5em 0}figure img,section.replay img,video{max-width:100%}
code{background:#f4f4f4;padding:0 2px} code.cmd{font-size:11px;white-space:nowrap}
.scroll{max-height:600px;overflow:auto;border:1px solid #ddd}
tr.failed td{background:#fff3f0}
"""

_SCRIPT = """
document.querySelectorAll('table.sortable').forEach(function(t){
  t.querySelectorAll('th').forEach(function(th,i){
    th.addEventListener('click',function(){
      var asc=!th.classList.contains('asc');
      t.querySelectorAll('th').forEach(function(h){h.classList.remove('asc','desc')});
      th.classList.add(asc?'asc':'desc');
      var body=t.tBodies[0], rows=Array.from(body.rows);
      function key(r){var s=r.cells[i]?r.cells[i].textContent.trim():'';var n=parseFloat(s);
        return (s!==''&&!isNaN(n)&&isFinite(s))?[0,n]:[1,s.toLowerCase()];}
      rows.sort(function(a,b){var x=key(a),y=key(b);
        var c=x[0]-y[0]||(x[1]<y[1]?-1:x[1]>y[1]?1:0);return asc?c:-c;});
      rows.forEach(function(r){body.appendChild(r)});
    });
  });
});
"""


def build_html(title: str, markdown: str, figures_png: Mapping[str, bytes], trials: pd.DataFrame,
               replays: Sequence[ReplayMedia], run_dir: str, grid_columns: Sequence[str] = ()) -> str:
    """The whole page: the report's Markdown (figures inline), the per-trial table and the replays."""
    images = {name: _data_uri("image/png", data) for name, data in figures_png.items()}
    body = markdown_to_html(markdown, images)
    n_failed = int((~trials["success"].astype(bool)).sum()) if "success" in trials.columns else 0
    trial_html = trial_table_html(trials, replays, run_dir, grid_columns)
    return "\n".join([
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(title)}</title>",
        f"<style>{_STYLE}</style></head><body>",
        body,
        '<h2 id="per-trial-results">Per-trial results</h2>',
        f"<p>{len(trials)} trials, {n_failed} failed. Click a column header to sort; a failed trial links to "
        "its replay where the run directory holds one, or gives the command that writes it.</p>",
        f'<div class="scroll">{trial_html}</div>',
        '<h2 id="replays">Replays</h2>',
        _replays_html(replays),
        f"<script>{_SCRIPT}</script>",
        "</body></html>",
    ]) + "\n"


def report_html(run_dir: str | Path, report: Any) -> str:
    """The HTML page of a built :class:`~offroadbench.study.report.markdown.Report` of ``run_dir``: its
    figures rendered in memory, the stored trials, the replays in ``run_dir/replays`` and ``run_dir``."""
    from offroadbench.study.report.header import report_title
    from offroadbench.study.store.results import load, load_meta

    run_dir = Path(run_dir)
    meta = load_meta(run_dir)
    trials = load(run_dir)
    figures = {name: figure_png(fig) for name, fig in report.figures.items()}
    replays = find_replays([run_dir / "replays", run_dir])
    return build_html(report_title(meta), report.markdown, figures, trials, replays, str(run_dir),
                      grid_columns=list(meta.get("columns", {}).values()))
