"""``offroadbench config [SECTION]``: a study table's defaults as TOML, and the settings reference.

The work is :mod:`offroadbench.reference`, which reads every key, default, unit and allowed range
from the config classes themselves. ``--write-reference PATH`` rewrites ``docs/reference.md``
(after a config field is added, run ``offroadbench config --write-reference docs/reference.md``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from offroadbench.cli._common import check_output_file, created_dirs


def cmd_config(args: argparse.Namespace) -> int:
    from offroadbench import reference

    if args.write_reference is not None:
        from offroadbench.io.atomic import atomic_path

        path = check_output_file(args.write_reference, "--write-reference")
        text = reference.render_reference()
        with created_dirs(path.parent), atomic_path(path) as tmp:
            Path(tmp).write_text(text, encoding="utf-8")
        print(f"wrote {path}")
        return 0
    print(reference.render_section_toml(args.section), end="")
    return 0


def register(sub) -> None:
    p = sub.add_parser(
        "config", help="print a study table with its defaults as TOML (start a study from it)",
        description="Print the tables of a study TOML with every key at its default, one comment per key "
        "(meaning, unit, allowed values). With no SECTION, the whole file: [study] (example values for its "
        "required keys), [grid] and [recipe_overrides] (empty, with commented examples), [roughness], [missions], "
        "[vehicle], [controller], [sim], [rules], [planner]. "
        "docs/reference.md documents the same keys and the output columns.")
    p.add_argument("section", nargs="?", default=None,
                   help="one table: study, grid, recipe_overrides, roughness, missions, vehicle, controller, sim, "
                   "rules, planner")
    p.add_argument("--write-reference", metavar="PATH", default=None,
                   help="write the Markdown settings reference to PATH (the repository's docs/reference.md)")
    p.set_defaults(func=cmd_config)
