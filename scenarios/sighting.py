"""The operator finds the insulator string in his cameras' pictures, before he plans the cleaning.

What a picture shows of a disc is its outline's left and right ends (the shed's silhouette, whole
pixels). What the operator knows is the disc type (its shed's diameter: the line's insulators are
of one type) and where his cameras stand and look (fixed, calibrated: scenarios/pinhole.py). Two
views (assets/scene.xml): the global camera, facing the string from the platform's side (world
x across its picture, z up it, y its depth), and the overhead camera looking down (x across, y up
its picture). From these:

- **how many discs**: the outlines the global view shows;
- **where the string stands across the global view's depth (world y)**: the middle of the top
  disc's outline in the overhead view, on its ray, at the top disc's height. The global view alone
  cannot give it well: the shed's width as a range cue (a shed of diameter D seen w pixels wide
  stands f D / w away) is 41 px at 640x480, and a pixel of it is ~9 cm of range (measured: the
  scene file's string found 7 cm off in y);
- **where each disc is**: the middle of its outline in the global view, on its ray, at that y;
- **the string's axis, pitch and top**: a straight line through the discs' centres fitted by least
  squares against the disc's number (centre_k = top - k pitch axis): the pitch is the line's step,
  the axis its direction, leaning where the string leans in the global view.

What he cannot see: a lean along the global view's depth (taken as none). The found string is
what the platform's plan is made for (scenarios/plan.py); the truth is only in the scene.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenarios.pinhole import Pinhole
from scenarios.string import Disc


@dataclass(frozen=True, kw_only=True)
class Sighting:
    """The string as the operator found it in the picture."""

    discs: list[Disc]  # top first
    range_m: float  # the string's mean distance from the global camera
    m_per_px: float  # what a pixel of the global view is at the string (his scale in that picture)
    pitch_m: float  # disc to disc along the axis (0 for a single disc)


def rays(pinhole: Pinhole, pixels: np.ndarray) -> np.ndarray:
    """Unit rays (k, 3) in the world from the camera through pixel coordinates (u right, v down)."""
    uv = np.atleast_2d(pixels)
    cam = np.column_stack(
        [
            (uv[:, 0] - pinhole.width_px / 2) / pinhole.focal_px,
            -(uv[:, 1] - pinhole.height_px / 2) / pinhole.focal_px,
            -np.ones(len(uv)),
        ]
    )
    world = cam @ pinhole.R_world_cam.T
    return world / np.linalg.norm(world, axis=1, keepdims=True)


def triangulate(front: Pinhole, front_px: np.ndarray, top: Pinhole, top_px: np.ndarray) -> np.ndarray:
    """World points (k, 3) seen at pixel coordinates (k, 2) in both views (whole pixels: their
    middles taken): the midpoint of the shortest segment between the two rays through each."""
    a = rays(front, np.asarray(front_px, dtype=float) + 0.5)
    b = rays(top, np.asarray(top_px, dtype=float) + 0.5)
    w = front.position_m - top.position_m
    ab, aw, bw = np.sum(a * b, axis=1), a @ w, b @ w
    denominator = np.maximum(1.0 - ab * ab, 1e-12)  # the views look across each other: never parallel
    s = (ab * bw - aw) / denominator  # along the front ray
    t = (bw - ab * aw) / denominator  # along the top ray
    return 0.5 * (front.position_m + s[:, None] * a + top.position_m + t[:, None] * b)


def silhouette_ends_px(pinhole: Pinhole, disc: Disc, samples: int = 360) -> np.ndarray:
    """(2, 2): the picture's leftmost and rightmost points of the disc's rim (its shed's outline)."""
    a = np.linspace(0.0, 2 * np.pi, samples, endpoint=False)
    frame = disc.frame()
    rim = disc.centre_m + disc.radius_m * (np.outer(np.cos(a), frame[:, 0]) + np.outer(np.sin(a), frame[:, 1]))
    uv = pinhole.project(rim)
    return np.array([uv[np.argmin(uv[:, 0])], uv[np.argmax(uv[:, 0])]])


def sight_string(
    front: Pinhole,
    front_ends_px: np.ndarray,
    top: Pinhole,
    top_ends_px: np.ndarray,
    radius_m: float,
    half_thickness_m: float,
) -> Sighting:
    """The string found from its discs' outline ends (n, 2, 2) in the global view and the top disc's
    (2, 2) in the overhead view, whole pixels, top first (see the module's docstring). A pixel
    index i spans [i, i + 1]: its middle is taken."""
    front_rays = rays(front, np.asarray(front_ends_px, dtype=float).mean(axis=1) + 0.5)
    top_ray = rays(top, np.asarray(top_ends_px, dtype=float).mean(axis=0) + 0.5)[0]
    depth_y = float(front.position_m[1] + 3.0 * radius_m)  # a first guess: refined in turn below
    for _ in range(4):  # the top disc's height (global view) and the string's y (overhead) set each other
        centres = front.position_m + ((depth_y - front.position_m[1]) / front_rays[:, 1])[:, None] * front_rays
        height = centres[0, 2]
        seen_from_above = top.position_m + (height - top.position_m[2]) / top_ray[2] * top_ray
        depth_y = float(seen_from_above[1])
    centres = front.position_m + ((depth_y - front.position_m[1]) / front_rays[:, 1])[:, None] * front_rays
    n = len(centres)
    if n > 1:
        k = np.arange(n, dtype=float)
        design = np.column_stack([np.ones(n), k])
        (start, step), *_ = np.linalg.lstsq(design, centres, rcond=None)
        pitch = float(np.linalg.norm(step))
        axis = -step / pitch
        centres = start + np.outer(k, step)
    else:
        pitch, axis = 0.0, np.array([0.0, 0.0, 1.0])
    mean_range = float(np.mean(np.linalg.norm(centres - front.position_m, axis=1)))
    discs = [Disc(centre_m=c, axis=axis, radius_m=radius_m, half_thickness_m=half_thickness_m) for c in centres]
    return Sighting(discs=discs, range_m=mean_range, m_per_px=mean_range / front.focal_px, pitch_m=pitch)
