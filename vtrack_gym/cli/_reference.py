"""The CLI reference page of the docs, generated from the parser (``docs/gen_cli_page.py`` writes it at build time,
so it cannot drift from the commands)."""

from __future__ import annotations

import argparse


def _cell(text: str) -> str:
    """``text`` as one Markdown table cell (one line; pipes and angle brackets escaped)."""
    return " ".join(text.split()).replace("|", "\\|").replace("<", "&lt;").replace(">", "&gt;")


def _value(action: argparse.Action) -> str:
    """What an option takes: its choices, else its metavar (or its name in capitals)."""
    if action.choices:
        return ", ".join(f"`{c}`" for c in action.choices)
    return f"`{action.metavar or action.dest.upper()}`"


def _option_rows(parser: argparse.ArgumentParser) -> list[str]:
    """One table row per option of ``parser``: names, choices or value, help (``%%`` and defaults expanded)."""
    rows = []
    for action in parser._actions:
        if not action.option_strings or action.dest == "help":
            continue
        names = ", ".join(f"`{o}`" for o in action.option_strings)
        value = "" if action.nargs == 0 else _value(action)
        text = (action.help or "") % {"default": action.default, "prog": parser.prog}
        rows.append(f"| {names} | {_cell(value)} | {_cell(text)}{' (required)' if action.required else ''} |")
    return rows


def cli_reference() -> str:
    """Every ``vtrack`` command's description and options, as Markdown."""
    from vtrack_gym.cli import build_parser

    parser = build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    helps = {c.dest: c.help for c in commands._choices_actions}
    lines = ["# CLI reference", "", "Generated from `vtrack`'s own parser. Every command also takes the global "
             "`-v/--verbose` (before or after the command); options are never abbreviated.", ""]
    for name, sub in commands.choices.items():
        lines += [f"## vtrack {name}", "", f"{helps.get(name) or ''}.", "", sub.description or "", "",
                  "| option | value | meaning |", "|---|---|---|", *_option_rows(sub), ""]
    return "\n".join(lines)
