"""Benchmark figures as text: what `twin bench` and `twin gap bench` print without --json."""

from __future__ import annotations


def figure_lines(figures: dict, indent: str = "") -> list[str]:
    """`twin bench`'s figures as indented `name: value` lines, nested tables (the plant's cases, the
    gap's campaigns) nested in turn; a repeated measurement as `median (min-max)`."""
    lines = []
    for k, v in figures.items():
        if isinstance(v, dict) and v.keys() == {"median", "min", "max"}:
            lines.append(f"{indent}{k}: {v['median']:g} ({v['min']:g}-{v['max']:g})")
        elif isinstance(v, dict):
            lines += [f"{indent}{k}:", *figure_lines(v, indent + "  ")]
        elif isinstance(v, list) and v and all(isinstance(item, dict) for item in v):
            lines.append(f"{indent}{k}:")
            for item in v:
                first, *rest = figure_lines(item, indent + "    ")
                lines += [f"{indent}  - {first.lstrip()}", *rest]
        else:
            lines.append(f"{indent}{k}: {v}")
    return lines
