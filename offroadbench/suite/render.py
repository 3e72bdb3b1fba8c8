"""A score card for people: Markdown (``score.md``) and one self-contained HTML page (``score.html``)."""

from __future__ import annotations

import html
from typing import Any, Mapping, Sequence

__all__ = ["card_markdown", "card_html", "fmt_ci", "PROFILE_NAME"]

#: the performance-profile figure's file name beside score.md
PROFILE_NAME = "profile.png"

_STYLE = ("body{font-family:system-ui,sans-serif;max-width:70em;margin:2em auto;padding:0 1em;line-height:1.4}"
          "table{border-collapse:collapse;margin:1em 0}th,td{border:1px solid #bbb;padding:.25em .6em}"
          "td{text-align:right}td:first-child{text-align:left}th{background:#eee}code{background:#f4f4f4}"
          "img{max-width:100%}")


def _f(x: Any, digits: int = 3) -> str:
    return "-" if x is None else f"{x:.{digits}g}" if isinstance(x, float) else str(x)


def fmt_ci(value: Any, ci: Sequence[Any] | None, digits: int = 3) -> str:
    """``0.812 [0.75, 0.86]``, or the value alone where there is no interval."""
    if value is None:
        return "-"
    if not ci or ci[0] is None:
        return _f(value, digits)
    return f"{_f(value, digits)} [{_f(ci[0], digits)}, {_f(ci[1], digits)}]"


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    """A pipe table (cells' own ``|`` escaped), then a blank line."""
    def line(cells: Sequence[Any]) -> str:
        return "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |"

    return [line(header), "|" + "|".join("---" for _ in header) + "|", *(line(r) for r in rows), ""]


def _category_rows(card: Mapping[str, Any]) -> list[list[str]]:
    rows = []
    for c in card["categories"]:
        fails = ", ".join(f"{k} {v}" for k, v in c["failures"].items()) or "none"
        rows.append([c["name"], f"{c['terrains']} / {c['tasks']}", fmt_ci(c["success_pct"]["mean"], c["success_pct"]["ci"]),
                     fmt_ci(c["time_s"]["mean"], c["time_s"]["ci"]), fmt_ci(c["ride_m_s2"]["mean"], c["ride_m_s2"]["ci"]),
                     fmt_ci(c["score"]["mean"], c["score"]["ci"]), _f(c["score_iqm"]), fails])
    return rows


def _comparison_rows(card: Mapping[str, Any], comparisons: Sequence[Mapping[str, Any]]) -> list[list[str]]:
    rows = []
    for cmp in comparisons:
        if not cmp["comparable"]:
            rows.append([cmp["baseline"], "-", "-", "-", "-", "-", f"not paired: {cmp['reason']}"])
            continue
        rows.append([cmp["baseline"], _f(cmp["baseline_score_iqm"]), _f(cmp["baseline_success_pct"]),
                     fmt_ci(cmp["score_diff"], cmp["score_diff_ci"]), fmt_ci(cmp["success_diff_pts"], cmp["success_diff_ci"]),
                     _f(cmp["p_sign_flip"], 2), f"{cmp['tasks_won']} / {cmp['tasks_tied']} / {cmp['tasks_lost']}"])
    return rows


def card_markdown(card: Mapping[str, Any], comparisons: Sequence[Mapping[str, Any]] = (),
                  image: str | None = PROFILE_NAME) -> str:
    """The card in Markdown: the suite version, the aggregate, the categories, the baselines beside."""
    s, o = card["suite"], card["overall"]
    lo, hi = s["time_clip_factors"]
    lines = [
        f"# {card['planner']} on {s['name']}, {s['tier']} tier",
        "",
        f"Suite **{s['name']}** (tasks sha256 `{s['tasks_sha256'][:12]}`), tier `{s['tier']}`: {s['tier_description']}. "
        f"Vehicle `{s['vehicle']}`, sensor `{s['sensor']}`, cruise speed {s['nominal_speed_m_s']:g} m/s. "
        f"Reproduce: `{card['command']}`. Code {card['run'].get('code_version', '?')}, "
        f"{card['run'].get('created', '?')}.",
        "",
        "## Score",
        "",
        f"**IQM score {fmt_ci(o['score_iqm'], o['score_iqm_ci'])}** over {o['terrains']} terrains ({o['tasks']} tasks; "
        f"success {fmt_ci(o['success_pct'], o['success_pct_ci'])} % per terrain, {o['successes']} of {o['tasks']} tasks"
        + (f"; {o['faults']} faults, scored 0" if o["faults"] else "") + ").",
        "",
        f"A task's score is success x nominal time / clip(actual time, {lo:g} x nominal, {hi:g} x nominal) (the BARN "
        "challenge's metric: Perille et al. 2020, Xiao et al. 2022), the nominal time being the start-goal distance "
        "over the cruise speed; a terrain's score is the mean over its missions. The aggregate is the interquartile "
        "mean over terrains with a 95 % stratified bootstrap interval (terrains resampled within each category), as "
        "rliable does (Agarwal et al. 2021). Intervals below resample terrains (a terrain's missions are not independent).",
        "",
        "## Categories",
        "",
        *_table(["category", "terrains / tasks", "success % [95 % CI]", "time of successes, s", "ride: RMS vertical "
                 "accel. of successes, m/s^2", "score (mean)", "score (IQM)", "failure modes (tasks)"], _category_rows(card)),
        *(f"- `{name}`: {text}" for name, text in s["categories"].items()),
        "",
    ]
    if comparisons:
        lines += ["## Against the shipped baselines (paired, same tasks)", "",
                  "Differences are this planner minus the baseline, per terrain, with 95 % stratified bootstrap "
                  "intervals; p is the exact sign-flip test over terrains (exploratory: no correction for the "
                  "number of baselines).", "",
                  *_table(["baseline", "its IQM score", "its success %", "score difference", "success difference, points",
                           "p (sign flip)", "tasks won / tied / lost"], _comparison_rows(card, comparisons))]
    if image:
        lines += ["## Performance profile", "", f"![performance profile]({image})", ""]
    return "\n".join(lines) + "\n"


def card_html(card: Mapping[str, Any], comparisons: Sequence[Mapping[str, Any]], profile_png: bytes | None) -> str:
    """One self-contained page: the Markdown card with the profile figure inline, then every task."""
    import base64

    from offroadbench.study.report import markdown_to_html

    images = {PROFILE_NAME: "data:image/png;base64," + base64.b64encode(profile_png).decode("ascii")} if profile_png else {}
    body = markdown_to_html(card_markdown(card, comparisons, PROFILE_NAME if profile_png else None), images)
    cols = ["category", "level", "terrain", "mission", "terrain_seed", "success", "failure_reason", "nominal_time_s",
            "traversal_time_s", "score", "rms_vertical_accel_m_s2"]
    head = "".join(f"<th>{html.escape(c)}</th>" for c in cols)
    rows = "".join("<tr>" + "".join(f"<td>{html.escape(_f(t.get(c)) if isinstance(t.get(c), float) else str(t.get(c, '')))}</td>"
                                    for c in cols) + "</tr>" for t in card["tasks"])
    title = f"{card['planner']} on {card['suite']['name']} ({card['suite']['tier']})"
    return "\n".join(["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">', f"<title>{html.escape(title)}</title>",
                      f"<style>{_STYLE}</style></head><body>", body, "<h2>Tasks</h2>",
                      f"<table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>", "</body></html>"]) + "\n"
