"""An arm design written to a folder: plan/ (an arm campaign's campaign.toml and one run CSV per
proposed run, commands at 1 ms, the instruments' columns left empty for the platform to fill),
design.json and design.md (gap.design_report's, with each run's exercise: the joint, its posture
and the gravity torque there), and predicted.png (every hypothesis's predicted angles of the top
run's exercised joint and of the departing joint, read by the instrument)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from gap.arm_campaign import JOINTS, campaign_toml, write_arm_run
from gap.arm_design import ArmDesign, changed
from gap.arm_replay import replay
from gap.design_report import as_json, markdown


def write_arm_design(a: ArmDesign, out: Path) -> dict[str, Path]:
    """plan/, design.json, design.md and (when a run is proposed) predicted.png in `out`."""
    out.mkdir(parents=True, exist_ok=True)
    paths = {"json": out / "design.json", "md": out / "design.md"}
    d = a.design
    if d.chosen:
        paths["plan"] = write_plan(a, out / "plan")
        paths["png"] = out / "predicted.png"
        plot(a).savefig(paths["png"], dpi=90)
    doc = as_json(d)
    doc["departing_joint"] = a.departing
    doc["exercises"] = {name: vars(e) for name, e in a.exercises.items()}
    paths["json"].write_text(json.dumps(doc, indent=1))
    paths["md"].write_text("\n".join(arm_markdown(a)) + "\n")
    return paths


def write_plan(a: ArmDesign, folder: Path) -> Path:
    """The chosen runs as an arm campaign to play: each run's commands, and empty columns for the
    angles of the joints the instrument sees (and the ports where the campaign measures them)."""
    folder.mkdir(parents=True, exist_ok=True)
    ports = a.arm_reading.floor_pa is not None
    blank = [(JOINTS[j], "angle_rad") for j in a.arm_reading.seen]
    blank += [(j, f) for j in JOINTS for f in ("p_a_pa", "p_b_pa")] if ports else []
    entries = []
    for r in a.design.runs():
        name = f"design_{r.name}.csv"
        write_arm_run(folder / name, r.run, blank=blank)
        entries.append((name, r.run.start_rad))
    text = campaign_toml(
        a.instrument,
        entries,
        a.payload_kg,
        a.arm,
        a.hose_loss,
        comment=f"runs proposed by twin gap design --arm from {a.design.source}; play them, fill the empty columns",
    )
    (folder / "campaign.toml").write_text(text)
    return folder


def arm_markdown(a: ArmDesign) -> list[str]:
    """gap.design_report's design.md, titled for the arm, with the exercise of every proposal."""
    lines = markdown(a.design)
    lines[0] = "# The next runs of the arm"
    if a.departing:
        lines[1:1] = ["", f"The diagnosis's departing joint: {a.departing}."]
    lines += [
        "",
        "## The exercises",
        "",
        "One joint at a time, the others braked, from rest in the posture (the base turned "
        f"{_base_deg(a):.0f} deg away from the string); separation: the lesser way round of the rival's "
        "refitted misfit, rms in noise floors over the run's samples.",
        "",
        "| run | joint | joint angle deg | gravity torque N·m | exercise | least separation (floors) | chosen |",
        "|---|---|---|---|---|---|---|",
    ]
    chosen = {p.protocol for p in a.design.chosen}
    for p in a.design.ranking:
        e = a.exercises[p.protocol]
        least = min(p.separation.values(), default=0.0)
        lines.append(
            f"| {p.protocol} | {e.joint} | {e.angle_deg:.0f} | {e.gravity_nm:+.1f} | {e.protocol} | {least:.2f} | "
            f"{'yes' if p.protocol in chosen else ''} |"
        )
    return lines


def _base_deg(a: ArmDesign) -> float:
    runs = [r for p in a.design.ranking for r in p.runs]
    return math.degrees(runs[0].run.start_rad[0]) if runs else 0.0


def plot(a: ArmDesign) -> Figure:
    """The top chosen run: every hypothesis's predicted angle of its exercised joint (and of the
    departing joint where that is another), as the instrument reads it (its latency)."""
    d = a.design
    run = d.chosen[0].runs[0]
    shown = list(dict.fromkeys(j for j in (run.exercise.joint, a.departing) if j))
    fig = Figure(figsize=(6.0 * len(shown), 3.6 + 0.2 * len(d.hypotheses)), layout="constrained")
    axes = fig.subplots(1, len(shown), squeeze=False)[0]
    for h in d.hypotheses:
        rep = replay(run.run, *changed(a.twin, h.effects))
        for ax, joint in zip(axes, shown, strict=True):
            j = JOINTS.index(joint)
            ax.plot(rep.time_s + h.latency_s, np.degrees(rep.angle_rad[:, j]), lw=1.2, label=h.name)
    for ax, joint in zip(axes, shown, strict=True):
        ax.set_title(f"{joint}: {run.exercise.label()}", fontsize=8)
        ax.set_ylabel("predicted drive angle as read, deg")
        ax.set_xlabel("time, s")
    least = min(d.chosen[0].separation.values(), default=0.0)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=2, fontsize=7)
    fig.suptitle(f"{run.name}: least separation {least:.2f} floors (noise {d.reading.floor_deg:.2f} deg)", fontsize=9)
    return fig
