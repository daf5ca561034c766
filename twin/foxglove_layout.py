"""The Foxglove layout shipped for the MCAP logs (assets/foxglove_layout.json): the arm in 3D with
the arm the controller believes in (translucent) and the camera's frustum, the global camera and
the controller's and operator's reports on the left; on the right one tab per joint with its
angles, angle error, chamber pressures, valve and brake, each plot one quantity in the unit the
rerun recording shows (degrees, bar). Import it in Foxglove (Layouts > Import from file) and open
a log of `twin run --mcap`.

    python -m twin.foxglove_layout [OUT.json]    # regenerates the shipped file

The plots read the channels twin.mcap_log writes; a joint's value in a foxglove.JointStates
message is picked by name (`.joints[:]{name=="wrist_pitch"}.position`), so the same layout serves
the arm and the one-joint wrist rig (tabs of joints a log lacks stay empty).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import assets
from twin.mcap_log import CALIBRATION_TOPIC, CAMERA_TOPIC, EVENTS_TOPIC

LAYOUT_PATH = assets.ASSETS_DIR / "foxglove_layout.json"
# dark-theme colours, as in the rerun recording (twin.rerun_log.SERIES_STYLES)
WHITE, ORANGE, BLUE, GREY = "#f5f5f5", "#ff8c00", "#3caaff", "#c8c8c8"
RED, GREEN, YELLOW = "#ff5a5a", "#6edc6e", "#ffd23c"


def _plot(title: str, series: list[tuple[str, str, str]]) -> dict:
    return {
        "title": title,
        "paths": [
            {"value": path, "enabled": True, "timestampMethod": "receiveTime", "label": label, "color": color}
            for path, label, color in series
        ],
        "showXAxisLabels": True,
        "showYAxisLabels": True,
        "showLegend": True,
        "legendDisplay": "floating",
        "isSynced": True,
        "xAxisVal": "timestamp",
    }


def _split(direction: str, items: list, shares: list[float] | None = None):
    """Foxglove's binary split tree over `items` (equal shares unless given)."""
    shares = shares or [1.0] * len(items)
    if len(items) == 1:
        return items[0]
    first = shares[0] / sum(shares)
    rest = _split(direction, items[1:], shares[1:])
    return {"first": items[0], "second": rest, "direction": direction, "splitPercentage": round(100 * first, 1)}


def joint_plots(j: str, k: int) -> tuple[dict, dict]:
    """The plots of joint `j` (panel ids carry its index `k`) and their split tree, in degrees and
    bar (the /joint/<j> channel's display fields, twin.mcap_log)."""
    port = f"/joint/{j}"
    plots = {
        f"Plot!{k}angle": _plot(
            f"{j}: angle (deg)",
            [
                (f"{port}.angle_true_deg", "true (plant)", WHITE),
                (f"{port}.angle_predicted_deg", "predicted (controller)", ORANGE),
                (f"{port}.angle_target_deg", "target", BLUE),
            ],
        ),
        f"Plot!{k}error": _plot(
            f"{j}: predicted − true (deg)",
            [
                (f"{port}.predicted_minus_true_deg", "predicted − true", ORANGE),
            ],
        ),
        f"Plot!{k}pressure": _plot(
            f"{j}: absolute pressure (bar)",
            [
                (f"{port}.pressure_a_bar", "chamber A", RED),
                (f"{port}.pressure_b_bar", "chamber B", BLUE),
                ("/arm.supply_bar", "supply", GREY),
            ],
        ),
        f"Plot!{k}valve": _plot(
            f"{j}: proportional valve, gauge (bar)",
            [
                (f"{port}.valve_gauge_bar", "prop. valve set pressure", GREEN),
            ],
        ),
        f"Plot!{k}commands": _plot(
            f"{j}: direction valve (-1, 0, +1) and brake (0 released, 1 holding)",
            [
                (f"{port}.direction", "direction valve", YELLOW),
                (f"{port}.brake_release", "brake release command", GREEN),
                (f"{port}.brake_engagement", "brake engagement", RED),
            ],
        ),
    }
    return plots, _split("column", list(plots), [3, 2, 2, 1.5, 1.5])


def layout(joints: tuple[str, ...] = assets.JOINTS, focus: str = "elbow_pitch") -> dict:
    """The layout as Foxglove stores it, opened on joint `focus`."""
    config: dict = {
        "3D!arm": {
            "followTf": "world",
            "scene": {"enableStats": False},
            # the true arm, the predicted one (its own frames predicted/<body>), the camera's frustum
            "topics": {t: {"visible": True} for t in ("/scene", "/scene/predicted", CALIBRATION_TOPIC)},
            "layers": {"grid": {"layerId": "foxglove.Grid", "visible": False}},  # the model's floor is drawn
        },
        "Image!camera": {"imageMode": {"imageTopic": CAMERA_TOPIC, "calibrationTopic": CALIBRATION_TOPIC}},
        "Plot!brush": _plot("brush normal force (N)", [("/arm.brush_force_n", "brush force", YELLOW)]),
        "RosOut!events": {"topicToRender": EVENTS_TOPIC, "searchTerms": [], "minLogLevel": 1},
    }
    tabs = []
    for k, j in enumerate(joints):
        plots, tree = joint_plots(j, k)
        config |= plots
        tabs.append({"title": j, "layout": tree})
    config["Tab!joints"] = {"activeTabIdx": joints.index(focus) if focus in joints else 0, "tabs": tabs}
    below = _split("row", ["Image!camera", "Plot!brush", "RosOut!events"])
    left = _split("column", ["3D!arm", below], [3, 1])
    return {
        "configById": config,
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": {"speed": 1.0},
        "layout": _split("row", [left, "Tab!joints"]),
    }


def topics_used(doc: dict) -> set[str]:
    """The channels a layout reads (a path's topic is what precedes its first '.')."""
    out = set()
    for panel in doc["configById"].values():
        for p in panel.get("paths", []):
            out.add(p["value"].split(".", 1)[0])
        out |= set(panel.get("topics", {}))
        if "imageMode" in panel:
            out |= {panel["imageMode"]["imageTopic"], panel["imageMode"]["calibrationTopic"]}
        if "topicToRender" in panel:
            out.add(panel["topicToRender"])
    return out


def write(path: Path = LAYOUT_PATH) -> Path:
    Path(path).write_text(json.dumps(layout(), indent=2) + "\n")
    return Path(path)


if __name__ == "__main__":
    print(write(Path(sys.argv[1]) if len(sys.argv) > 1 else LAYOUT_PATH))
