"""A scene camera's frames, recorded at its frame rate as the world points they show.

A camera that watches the arm (the operator's, scenarios/operator.py) needs, per frame, only a
few points of the scene: a body's origin and axis, other bodies' origins, a site. `record_frame`
copies them from MuJoCo's arrays into a ring of rows when a frame is due; the picture (the
points projected to pixels) is made from a row when someone looks at it. It is compiled so that
the run loop's compiled ticks (twin/compiled_loop.py) take frames without returning to Python,
and the Python tick calls the same function: a frame is the same either way.

    clock: [when the next frame is due (s), the period (s), frames taken so far]
    row:   [time, origin (3) and x axis (3) of body_ids[0], origins (3 each) of body_ids[1:],
            positions (3 each) of site_ids]
"""

from __future__ import annotations

import math

import numpy as np

from pneumatics._jit import njit

CLOCK_NEXT_S, CLOCK_PERIOD_S, CLOCK_TAKEN = range(3)


def row_size(n_bodies: int, n_sites: int) -> int:
    """Length of a frame's row with n_bodies bodies (the first with its axis) and n_sites sites."""
    return 1 + 3 + 3 * n_bodies + 3 * n_sites


@njit
def record_frame(clock, rows, body_ids, site_ids, xpos, xmat, site_xpos, time_s) -> None:
    """Take a frame at `time_s` into `rows` (a ring) if one is due: at or after the due time
    less 1e-9 s (a tick's time summed by MuJoCo lands within round-off of the frame's); the next
    frame is due a whole number of periods later, the first after `time_s`."""
    if time_s + 1e-9 < clock[CLOCK_NEXT_S]:
        return
    row = rows[int(clock[CLOCK_TAKEN]) % rows.shape[0]]
    row[0] = time_s
    head = body_ids[0]
    for i in range(3):
        row[1 + i] = xpos[head, i]
        row[4 + i] = xmat[head, 3 * i]  # the body's x axis: xmat's first column
    c = 7
    for b in range(1, body_ids.shape[0]):
        for i in range(3):
            row[c + i] = xpos[body_ids[b], i]
        c += 3
    for s in range(site_ids.shape[0]):
        for i in range(3):
            row[c + i] = site_xpos[site_ids[s], i]
        c += 3
    clock[CLOCK_TAKEN] += 1.0
    period = clock[CLOCK_PERIOD_S]
    clock[CLOCK_NEXT_S] += period * max(1, math.floor((time_s - clock[CLOCK_NEXT_S]) / period) + 1)


def no_camera() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(clock, rows, body_ids, site_ids) of a camera that never takes a frame."""
    return np.array([math.inf, 1.0, 0.0]), np.zeros((1, row_size(1, 0))), np.zeros(1, np.int64), np.zeros(0, np.int64)
