"""`twin paper`'s plots and report.md: every number beside the paper's, every plot titled with
what it shows (scenarios/paper.py makes the numbers)."""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

KIND_LABEL = {"with_hose_loss": "with hose loss", "without_hose_loss": "without hose loss"}


def _yes(holds: bool) -> str:
    return "yes" if holds else "NO"


def _ratio(twin: float, paper: float) -> str:
    return f"{twin / paper:.2f}" if paper else "-"


def _save(fig: Figure, out: Path, name: str) -> None:
    fig.tight_layout()
    fig.savefig(out / name, dpi=100)


def _finish(fig: Figure, ax, labels: tuple[str, str, str], out: Path, name: str) -> None:
    """Label the axes (x, y, title), add the legend and save."""
    xlabel, ylabel, title = labels
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=7)
    _save(fig, out, name)


def _plot_timeseries(series: dict, mpas: list, out: Path) -> None:
    fig = Figure(figsize=(3.2 * len(mpas), 3.2))
    axes = fig.subplots(1, len(mpas), sharey=True)
    for ax, m in zip(axes, mpas, strict=True):
        s = series[m]
        ax.plot(s["time_s"], s["measured_deg"], "k-", label="measured (as-built plant)")
        ax.plot(s["time_s"], s["with_hose_loss"], "-", label="model with hose loss")
        ax.plot(s["time_s"], s["without_hose_loss"], "--", label="model without hose loss")
        ax.axvline(1.0, color="grey", lw=0.8, ls=":")
        ax.set_title(f"{m} MPa", fontsize=9)
        ax.set_xlabel("time, s (valve open 0-1 s)")
    axes[0].set_ylabel("rotation from start, deg")
    axes[0].legend(fontsize=6)
    fig.suptitle("Fig. 10-13 in the twin: wrist rotation, valve fully open 1 s", fontsize=10)
    _save(fig, out, "validation_timeseries.png")


def _plot_prediction_error(r: dict, mpas: list, out: Path) -> None:
    pe = r["prediction_error"]["errors"]
    fig = Figure(figsize=(9, 3.5))
    axes = fig.subplots(1, 2)
    for ax, stat in zip(axes, ("mean", "max"), strict=True):
        for kind, mark in (("without_hose_loss", "o"), ("with_hose_loss", "s")):
            ax.plot(mpas, [pe[m][kind][stat] for m in mpas], mark + "-", label=f"twin, {KIND_LABEL[kind]}")
            ax.plot(
                mpas,
                [pe[m][kind]["paper_" + stat] for m in mpas],
                mark + "--",
                alpha=0.6,
                label=f"paper, {KIND_LABEL[kind]}",
            )
        ax.set_xlabel("supply pressure, MPa (gauge)")
        ax.set_ylabel(f"{stat} |measured - predicted| over 1 s, deg")
        ax.set_title(f"Fig. 14-16: {stat} prediction error", fontsize=10)
    axes[0].legend(fontsize=7)
    _save(fig, out, "prediction_error.png")


def _plot_error_vs_angle(series: dict, mpas: list, out: Path) -> None:
    fig = Figure(figsize=(9, 3.5))
    axes = fig.subplots(1, 2, sharey=True)
    for ax, kind in zip(axes, ("with_hose_loss", "without_hose_loss"), strict=True):
        for m in mpas:
            s = series[m]
            n = sum(1 for t in s["time_s"] if t <= 1.0 + 1e-9)
            ax.plot(
                s["measured_deg"][:n],
                [abs(a - b) for a, b in zip(s["measured_deg"][:n], s[kind][:n], strict=False)],
                label=f"{m} MPa",
            )
        ax.set_xlabel("measured rotation, deg")
        ax.set_title(
            f"Fig. {15 if kind == 'with_hose_loss' else 16}: error against angle, model {KIND_LABEL[kind]}", fontsize=9
        )
    axes[0].set_ylabel("|measured - predicted|, deg")
    axes[0].legend(fontsize=7)
    _save(fig, out, "error_vs_angle.png")


def _plot_speed(r: dict, out: Path) -> None:
    sp = r["prediction_error"]["speed_against_supply"]
    ps = sorted(sp)
    fig = Figure(figsize=(6, 3.5))
    ax = fig.subplots()
    ax.plot(ps, [sp[m]["as_built_mean_deg_s"] for m in ps], "ko-", label="as-built plant, mean over 0.5-1 s")
    ax.plot(ps, [sp[m]["as_built_peak_deg_s"] for m in ps], "k^:", label="as-built plant, peak")
    ax.plot(ps, [sp[m]["nominal_mean_deg_s"] for m in ps], "s-", label="nominal model, mean over 0.5-1 s")
    ax.axhline(
        r["prediction_error"]["max_power_joint_deg_s"], color="r", ls="--", label="motor at max power (6000 rpm / 120)"
    )
    labels = ("supply pressure, MPa (gauge)", "joint speed, deg/s", "Wrist speed against supply, valve fully open")
    _finish(fig, ax, labels, out, "speed_vs_supply.png")


def _plot_random_supply(r: dict, out: Path) -> None:
    rs = r["random_supply"]
    fig = Figure(figsize=(6, 4.5))
    top, bottom = fig.subplots(2, 1, sharex=True)
    top.step(rs["supply_time_s"], rs["supply_gauge_mpa"], where="post")
    top.set_ylabel("supply, MPa (gauge)")
    top.set_title("Fig. 18-19: random supply (0.5 s each) and the final error of each move", fontsize=10)
    bottom.plot(rs["move_end_s"], rs["final_errors_deg"], "o", label="twin, |final error| of a move")
    bottom.axhline(rs["paper_max_error_deg"], color="r", ls="--", label="paper, max 4.33 deg")
    _finish(fig, bottom, ("time, s", "|final error|, deg", ""), out, "random_supply.png")


def _plot_closed_vs_open(r: dict, out: Path) -> None:
    co = r["closed_vs_open_loop"]
    fig = Figure(figsize=(6, 3.5))
    ax = fig.subplots()
    ax.plot(co["angles_deg"], co["closed_loop_error_deg"], ".-", label="twin, closed loop")
    ax.plot(co["angles_deg"], co["open_loop_error_deg"], ".-", label="twin, open loop")
    for (lo, hi), label in (
        (co["paper_closed_loop_range_deg"], "paper, closed"),
        (co["paper_open_loop_range_deg"], "paper, open"),
    ):
        ax.axhspan(lo, hi, alpha=0.15, label=f"{label} ({lo}-{hi} deg)")
    labels = ("commanded rotation, deg", "|final error|, deg", "Fig. 23: closed against open loop at 0.5 MPa")
    _finish(fig, ax, labels, out, "closed_vs_open_loop.png")


def _plot_error_vs_pressure(r: dict, out: Path) -> None:
    ep = r["error_vs_pressure"]
    fig = Figure(figsize=(6, 3.5))
    ax = fig.subplots()
    ax.plot(
        ep["pressures_mpa"], ep["mean_error_deg"], "o-", label=f"arm's loop (brakes), final, mean {ep['angles_deg']}"
    )
    ax.plot(ep["pressures_mpa"], ep["max_error_deg"], "^:", label="arm's loop (brakes), final, max")
    held = ep["fig17_loop"]
    ax.plot(
        ep["pressures_mpa"],
        held["true_mean_error_deg"],
        "s-",
        label=f"Fig. 17's loop held on the valve, true, mean {held['angles_deg'][0]}-{held['angles_deg'][-1]}",
    )
    ax.plot(ep["pressures_mpa"], held["predicted_mean_error_deg"], "s--", label="the same, its own (predicted)")
    ax.axhline(ep["paper_bound_at_05_deg"], color="r", ls="--", label="paper: within 3 deg at 0.5 MPa")
    labels = ("supply pressure, MPa (gauge)", "closed-loop |error|, deg", "Fig. 20: control error against supply")
    _finish(fig, ax, labels, out, "error_vs_pressure.png")


def write_plots(r: dict, series: dict, out: Path) -> None:
    """The paper's figures as the twin draws them, one PNG each, into `out`."""
    mpas = sorted(series)
    _plot_timeseries(series, mpas, out)
    _plot_prediction_error(r, mpas, out)
    _plot_error_vs_angle(series, mpas, out)
    _plot_speed(r, out)
    _plot_random_supply(r, out)
    _plot_closed_vs_open(r, out)
    _plot_error_vs_pressure(r, out)


def _as_built_lines(r: dict) -> list[str]:
    lines = [
        "# The paper's experiments in the twin",
        "",
        "Generated by `twin paper`"
        + (" --quick (control experiments shortened)" if r["quick"] else "")
        + ". Reality is the "
        "as-built wrist (below), the predictor the nominal model; the validation's calibrated effects were fitted on "
        "Fig. 10-16 only, everything after it is a prediction.",
        "",
        "## The as-built wrist (assets/as_built/wrist_pitch.toml)",
        "",
        "| field | nominal | as-built | source | basis |",
        "|---|---|---|---|---|",
    ]
    return lines + [
        f"| {e['field']} | {e['nominal']:g} | {e['as_built']:g} | {e['source']} | {e['basis']} |" for e in r["as_built"]
    ]


def _ratios(pe: dict) -> str:
    """Twin/paper ratios of the mean and max error, with / without the hose loss, per supply."""
    return "; ".join(
        f"{m} MPa {_ratio(pe[m]['with_hose_loss']['mean'], pe[m]['with_hose_loss']['paper_mean'])}, "
        f"{_ratio(pe[m]['with_hose_loss']['max'], pe[m]['with_hose_loss']['paper_max'])} / "
        f"{_ratio(pe[m]['without_hose_loss']['mean'], pe[m]['without_hose_loss']['paper_mean'])}, "
        f"{_ratio(pe[m]['without_hose_loss']['max'], pe[m]['without_hose_loss']['paper_max'])}"
        for m in sorted(pe)
    )


def _minimum_rotation_line(mr: dict) -> str:
    """Fig. 21's sentence; `limit_deg` None: not even the largest tested rotation is adjusted."""
    paper = f"about {mr['paper_limit_deg']:.0f} deg in the paper."
    if mr["limit_deg"] is None:
        return f"The loop adjusts at none of the tested rotations (up to {max(mr['tested_deg'])} deg; twin), {paper}"
    return f"The loop adjusts from {mr['limit_deg']} deg of commanded rotation up (twin), {paper}"


def _validation_lines(pv: dict) -> list[str]:
    pe = pv["errors"]
    lines = [
        "",
        "## Model validation, Fig. 10-16: |measured - predicted| over the 1 s the valve is fully open, deg",
        "",
        "| supply MPa | with loss: mean (paper) | max (paper) | without loss: mean (paper) | max (paper) "
        "| mean gap of the two models |",
        "|---|---|---|---|---|---|",
    ]
    for m in sorted(pe):
        w, wo = pe[m]["with_hose_loss"], pe[m]["without_hose_loss"]
        lines.append(
            f"| {m} | {w['mean']:.1f} ({w['paper_mean']}) | {w['max']:.1f} ({w['paper_max']}) | "
            f"{wo['mean']:.1f} ({wo['paper_mean']}) | {wo['max']:.1f} ({wo['paper_max']}) | "
            f"{pe[m]['predictor_gap_mean_deg']:.1f} |"
        )
    return lines + [
        "",
        "Twin/paper ratios (mean, max; with / without): " + _ratios(pe) + ".",
        "",
        f"With the loss smaller than without at every supply: {_yes(pv['with_smaller_than_without_everywhere'])}; "
        f"the mean error grows as the supply falls (paper: both): "
        f"with the loss {_yes(pv['with_grows_as_pressure_falls'])}, "
        f"without it {_yes(pv['without_grows_as_pressure_falls'])}.",
        "The last column is the mean distance between the two nominal predictions themselves: "
        "no reality can have both errors smaller than half of it, so where it exceeds the paper's two means added "
        + ", ".join(f"({pe[m]['paper_gap_bound_deg']:.1f} deg at {m} MPa)" for m in sorted(pe))
        + " the paper's pair cannot be met by any as-built arm; only a change of the nominal model could. "
        "Out of reach here (the same test on the max): "
        + (
            ", ".join(
                f"{m} MPa {' and '.join(pe[m]['paper_pair_unreachable'])}"
                for m in sorted(pe)
                if pe[m]["paper_pair_unreachable"]
            )
            or "none"
        )
        + "; the fit of the calibrated effects leaves those figures without the loss out "
        "(scenarios/paper_validation.py, `misfit`).",
        "",
        "![Fig. 10-13 time series](validation_timeseries.png)",
        "",
        "![prediction error](prediction_error.png)",
        "",
        "![error against angle](error_vs_angle.png)",
        "",
    ]


def _speed_lines(pv: dict) -> list[str]:
    lines = [
        "## Joint speed against supply (valve fully open)",
        "",
        "| supply MPa | as-built mean 0.5-1 s | as-built peak | nominal model mean | turn in 1 s |",
        "|---|---|---|---|---|",
    ]
    sp = pv["speed_against_supply"]
    for m in sorted(sp):
        s = sp[m]
        lines.append(
            f"| {m} | {s['as_built_mean_deg_s']:.0f} | {s['as_built_peak_deg_s']:.0f} | "
            f"{s['nominal_mean_deg_s']:.0f} | {s['turn_in_1s_deg']:.0f} |"
        )
    return lines + [
        "",
        f"deg/s; the motor's maximum-power point (6000 rpm, paper Sec. III-B) is "
        f"{pv['max_power_joint_deg_s']:.0f} deg/s at the joint "
        "through 1:120. The exhaust throttle (0.8 mm^2) holds the joint's steady speed well below it "
        '(docs/validation/as_built_and_paper.md, "Joint speed against supply").',
        "",
        "![speed against supply](speed_vs_supply.png)",
        "",
    ]


def _random_supply_lines(r: dict) -> list[str]:
    """Fig. 18-19 (random supply) and Fig. 21 (minimum rotation)."""
    rs = r["random_supply"]
    return [
        "## Random supply, Fig. 18-19",
        "",
        f"Largest final error of {len(rs['final_errors_deg'])} moves (0, 45, 0, -45, 0 deg) "
        f"over {rs['duration_s']:.0f} s under a "
        f"supply drawn every 0.5 s (mean 0.6 MPa, variance 5e9 Pa^2): twin {rs['max_error_deg']:.2f} deg, paper "
        f"{rs['paper_max_error_deg']} deg (manual operation {rs['paper_manual_mean_deg']} deg on average).",
        "",
        "![random supply](random_supply.png)",
        "",
        "## Minimum rotation, Fig. 21",
        "",
        _minimum_rotation_line(r["minimum_rotation"]),
        "",
    ]


def _trend_words(trend: dict) -> str:
    return (
        f"{_yes(trend['grows'])} (Spearman's rho {trend['spearman_rho']:+.2f}, p = {trend['p_value']:.3f} over "
        "the rotations)"
    )


def _rotations_line(angles: list) -> str:
    every_degree = list(angles) == list(range(angles[0], angles[-1] + 1))
    return f"{len(angles)} rotations, {angles[0]}-{angles[-1]} deg" + (
        " in 1 deg steps, as the paper; the table shows every 10 deg, the plot and paper.json all."
        if every_degree
        else " (the paper's protocol: every 1 deg)."
    )


def _closed_vs_open_lines(co: dict) -> list[str]:
    lines = [
        "## Closed against open loop at 0.5 MPa, Fig. 23 (|final error|, deg)",
        "",
        _rotations_line(co["angles_deg"]),
        "",
        "| rotation deg | closed loop | open loop |",
        "|---|---|---|",
    ]
    rows = zip(co["angles_deg"], co["closed_loop_error_deg"], co["open_loop_error_deg"], strict=True)
    for a, c, o in rows:
        if len(co["angles_deg"]) <= 10 or a % 10 == 0:
            lines.append(f"| {a} | {c:.2f} | {o:.2f} |")
    return lines + [
        "",
        f"Twin: closed {min(co['closed_loop_error_deg']):.2f}-{max(co['closed_loop_error_deg']):.2f} deg (mean "
        f"{co['closed_loop_mean_deg']:.2f}), "
        f"open {min(co['open_loop_error_deg']):.2f}-{max(co['open_loop_error_deg']):.2f} deg (mean "
        f"{co['open_loop_mean_deg']:.2f}). "
        f"Paper: closed {co['paper_closed_loop_range_deg'][0]}-{co['paper_closed_loop_range_deg'][1]} deg (mean "
        f"{co['paper_closed_loop_mean_deg']}), "
        f"open {co['paper_open_loop_range_deg'][0]}-{co['paper_open_loop_range_deg'][1]} deg. "
        f"Closed loop beats open loop at every angle: {_yes(co['closed_beats_open_everywhere'])}. "
        f"The open loop's error grows with the rotation (paper: yes): {_trend_words(co['open_trend'])}; "
        f"the closed loop's (paper: yes): {_trend_words(co['closed_trend'])}. "
        f"The open loop's own prediction lands within {max(co['open_loop_predicted_error_deg']):.2f} deg of "
        "each target: its error is the as-built joint falling behind the nominal model (docs/validation/"
        'as_built_and_paper.md, "What remains off").',
        "",
        "![closed vs open loop](closed_vs_open_loop.png)",
        "",
    ]


def _error_vs_pressure_lines(ep: dict) -> list[str]:
    lines = [
        "## Control error against supply, Fig. 20 (closed loop, |final error|, deg)",
        "",
        "| supply MPa | " + " | ".join(f"{a} deg" for a in ep["angles_deg"]) + " | mean |",
        "|---|" + "---|" * (len(ep["angles_deg"]) + 1),
    ]
    for m, mean in zip(ep["pressures_mpa"], ep["mean_error_deg"], strict=True):
        lines.append(f"| {m} | " + " | ".join(f"{e:.2f}" for e in ep["errors_deg"][str(m)]) + f" | {mean:.2f} |")
    return (
        lines
        + [
            "",
            f"Paper: the error grows with the supply, within +-{ep['paper_bound_at_05_deg']:.0f} deg at 0.5 MPa. "
            f"Twin (the arm's loop, braking on arrival): grows with the supply: {_yes(ep['grows_with_pressure'])}.",
            "",
        ]
        + _held_lines(ep)
        + [
            "",
            "![error against pressure](error_vs_pressure.png)",
            "",
        ]
    )


def _held_lines(ep: dict) -> list[str]:
    # Fig. 20 under Fig. 17's loop as drawn (scenarios/paper.py `_held_vs_pressure`)
    h = ep["fig17_loop"]
    row = " | ".join(f"{m}" for m in ep["pressures_mpa"])
    return [
        f"Fig. 17's loop as drawn (the PID holds the joint on the valve, no hand-over to the brake), moves of "
        f"{h['angles_deg']} deg, the largest |error| over the last {h['window_s']:g} s of {h['hold_s']:g} s, mean "
        "over the moves (deg):",
        "",
        f"| supply MPa | {row} |",
        "|---|" + "---|" * len(ep["pressures_mpa"]),
        "| true (as-built) | " + " | ".join(f"{e:.2f}" for e in h["true_mean_error_deg"]) + " |",
        "| its own (predicted) | " + " | ".join(f"{e:.2f}" for e in h["predicted_mean_error_deg"]) + " |",
        "",
        f"Grows with the supply: true {_yes(h['true_grows_with_pressure'])}, "
        f"its own {_yes(h['predicted_grows_with_pressure'])}; largest true error at 0.5 MPa "
        f"{h['true_max_error_deg'][0]:.2f} deg (paper: within +-{ep['paper_bound_at_05_deg']:.0f}).",
    ]


def write_report(r: dict, out: Path) -> Path:
    """report.md in `out`: each experiment's numbers beside the paper's, section by section."""
    pv = r["prediction_error"]
    lines = (
        _as_built_lines(r)
        + _validation_lines(pv)
        + _speed_lines(pv)
        + _random_supply_lines(r)
        + _closed_vs_open_lines(r["closed_vs_open_loop"])
        + _error_vs_pressure_lines(r["error_vs_pressure"])
    )
    report = out / "report.md"
    report.write_text("\n".join(lines))
    return report
