"""The operator on the platform, who watches the global camera and corrects the arm by eye.

The paper's arm has no angle sensors; its operators steer by a camera that shows the whole arm and
the insulator string (paper Sec. II). This model sees only what that camera's picture shows:

- **the camera** (`GlobalCamera`): the scene's `global_view`, a pinhole of the same pose and field
  of view MuJoCo renders (scenarios/pinhole.py), at `width_px` x `height_px` and `camera_fps`. Each
  frame holds where the brush's face and each disc's rim facing the arm are in the picture, in
  whole pixels (the eye cannot place an edge better than a pixel), the string's disc spacing in
  it, and where the shoulder, elbow and wrist axes are.
  The camera is a device in the world: it reads the scene, the operator reads only its frames.
- **the eye**: a frame is seen `latency_s` after it was taken (video link plus reaction). Depth
  along the optical axis is what one camera cannot see: the operator judges the error in the
  picture's plane only, with the scale of the string (he needs no distance), and takes the
  picture's plane for the arm's (the camera looks 10 deg down: the vertical error is read 1.6 %
  short). The scale is the string's: its discs' known
  spacing (the far half of each disc is hidden behind the gantry's front post, so not its width).
  The arm works in the plane the camera faces,
  so the press depth (along x) and the height are both in the picture; what he cannot see, the
  brush's offset along y, changes the rim's x under the brush by only r - sqrt(r^2 - y^2)
  (0.4 mm at 1 cm).
- **the hands**: whenever the brush stands clear of a disc (at 12-15 cm on its way, or 5 cm off
  ready to press; a drift left until the press had by then rammed a disc on the way, 155 N against
  the as-built arm), he reads the arm's pose off the picture (the pitch of the upper arm, the
  forearm and the tool: the lines between the shoulder, elbow and wrist axes and the brush, as
  seen) and sets the platform's predicted shoulder, elbow and wrist angles to it (the predictor
  drifts, its load model with it: once it is 10-20 deg off, a small move it commands is a fraction
  of that in truth; measured in this run, 3 deg commanded, 0.3-0.6 deg done). The base yaw turns
  the arm along the global view's depth: he reads it from the overhead camera (`top_view`), the
  bearing of the brush's carrier from the base axis, the carrier placed by both views (left
  unread, it stopped 6.5 deg short of the plan with the string turned 6 deg, unnoticed, and disc 1
  was pressed at 59 N). He resets the belief only
  where it is off by more than the picture's own noise (REREAD_PX); then, ready to press, he
  compares the brush's face with where it should stand (the standoff in front of the rim) and,
  while the error is over `tolerance_m`, moves the brush's aim by the error he sees and lets the
  platform go there again (its inverse kinematics, as a jog handle in the tool's frame would). The
  aim carries to the press and the back-off on that disc, and to the next disc. At most MAX_LOOKS
  looks per disc; then he aims the press by his last look. Placed at the plan's standoff, he
  closes in to 2 cm and looks again before he presses (scenarios/task.TOUCH_STANDOFF_M). Where
  his aim would take a joint past its range (the wrist at the bottom disc) the tool is tilted instead
  (scenarios/ik.tip_drive_angles): he places the brush, not its tilt; an aim the platform refuses
  anyway he takes back. Pressed, he looks once more: the head's stroke (its face against its
  carrier, along the tool) is the spring's force; off the plan's by more than `tolerance_m`, he
  moves the press along it by what he sees, backs out to touching distance and presses again from
  there (MAX_PRESS_LOOKS a disc; scenarios/task.py). Pressing
  blind, the press landed 25 +- 15 mm (the 2 cm placement's centimetre, the arrival band's
  half-degree on shoulder and elbow, the elbow's inexact small moves): 13 N at worst.
  A link 0.5 m long is ~80 px in the picture: a pixel at each end is ~0.7 deg of pitch.
- **what he does not press on with**: a pose seen so far from the platform's belief (a joint
  IMPLAUSIBLE_RAD off, or the brush to go further into the rim than a press would) that going to
  the target again could ram the rim: he sets the belief to what he sees, stops and
  backs off clear of the string (scenarios/task.py) and comes in again, looking at each standoff;
  a third such look on a disc and he leaves it unpressed. The head seen pushed in with its face
  clear of the rim (nothing can push it: a misreading, or a jammed head): he backs out and does
  not press again by it.
- **what a coarse picture allows**: he places the brush no finer than a pixel at the string
  (`OperatorParams.tolerance_m`); a joint his picture gives coarser than UNREADABLE_RAD he does not read;
  with a pixel coarser than his tolerance (`Operator.coarse`), a correction that would move the
  brush across the rim's normal further than it stands off the rim, nearer than the plan's
  clearance, is taken as a possible misreading and made from clear of the string, and a press is
  corrected only when seen off by more than his tolerance and a pixel (the stroke's two ends are
  each cut to one).
- **a brush seen on the rim where it should stand clear** (its face's centre on or past the rim at
  a standoff): he sets the belief to what he sees and draws it straight out along the rim's normal
  before anything else (scenarios/task.py, DRAWING_OUT), then looks again.
- **before the plan's last turn back into the camera's plane** (the retreat's swing from aside of the
  string) he looks from both views whether the brush, turned back, would pass nearer the string than
  touching distance, and if the shoulder stands short of where the platform believes it, sets the
  belief by the carrier seen and lets the shoulder's raise be sent again (`review_swing`).

Numbers (the paper gives none for its camera): 640 x 480 at 25 frames/s, an analogue CCTV
camera's picture (PAL, assumed); latency 0.4 s = about 0.1 s of video link and encoding plus a
human visual reaction time of 0.2-0.3 s (assumed, textbook simple reaction times), drawn
for each look within +-25 % from the scenario's seed; tolerance
1 cm: the brush head's 25 mm working press (of its 50 mm stroke, assets/arm.xml) then stays
between 18 and 42 N.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from scenarios.ik import (
    BRUSH_HALF_LENGTH_M,
    arm_lengths,
    carrier_m,
    drive_to_qpos,
    joint_out_of_range,
    tip_drive_angles,
    tool_drive_angles,
)
from scenarios.pinhole import Pinhole, camera_of
from scenarios.plan import CLEAR_M, PRESS_M, TOUCH_STANDOFF_M
from scenarios.schema import OperatorParams
from scenarios.sighting import Sighting, sight_string, silhouette_ends_px, triangulate
from scenarios.string import believed_disc_type, discs_of
from twin.camera_frames import CLOCK_NEXT_S, CLOCK_TAKEN, record_frame, row_size

LATENCY_SPREAD = 0.25  # each look's latency is latency_s x (1 +- this), uniform (assumed: reaction times scatter ~25 %)
MAX_LOOKS = 6  # corrections per disc before the operator presses, aimed by his last look
# how many times a disc he draws the brush straight out, seen on its rim where a target holds it clear,
# before he takes such a look as any other (a draw-out that does not take it off the rim is not repeated)
DRAW_OUTS_PER_DISC = 2
# corrections of a press's depth per disc (he presses again by what he sees, then lets it be): the
# platform's own error over a press, 1-2 cm (the arrival band, 0.5 deg on each of shoulder and
# elbow, ~4 mm each at the brush; the as-built elbow's small moves 1-3 times the predicted),
# is what one correction takes out
MAX_PRESS_LOOKS = 2
# the platform's belief is reset from the picture when a joint's seen pitch is further off than
# REREAD_PX pixels at the ends of the shortest link that sets it (0.7 deg for the 80 px upper arm,
# 4.6 deg for the 25 px tool), so a reading's own noise does not trigger it
REREAD_PX = 2.0
# a joint seen this far from the platform's belief is not a drift to correct at the rim: a pose
# that far off (the elbow arriving 29 deg off at disc 1's first approach, as-built, 0.5 MPa; a coarse
# 160x120 picture misread the wrist by 22 deg and drove the brush into disc 2 at 278 N) is checked
# clear of the string before the arm is sent anywhere by it
IMPLAUSIBLE_RAD = math.radians(20.0)
# a joint read off the picture more coarsely than this (REREAD_PX over its shortest link, in rad) is
# not read: at 160x120 the 6 px tool gives the wrist to 19 deg, and a wrist set 20 deg off by such a
# reading tilted the head into disc 5 at 1145 N; at 320x240 (12 px, 9.5 deg) it is still read
UNREADABLE_RAD = math.radians(10.0)
ARM_POINTS = ("upper_arm", "forearm", "wrist")  # bodies whose origins are the shoulder, elbow, wrist axes
CAMERA = "global_view"
OVERHEAD = "top_view"  # the overhead camera: where the string stands across the global view's depth
# the joints he leaves where they stand when they do not move by a small move (`Operator.hold`): the
# base yaw only, which turns the arm's plane and moves the brush along the global view's depth
# alone; a pitch joint held would move the brush in the picture, where he places it by the others
HELD = ("base_yaw",)
FRAMES_KEPT = 64  # the camera's last frames kept (2.6 s at 25 frames/s: longer than any look's latency)


@dataclass(frozen=True, kw_only=True)
class Frame:
    time_s: float
    brush_px: np.ndarray  # (2,) centre of the brush's face, whole pixels (u right, v down)
    rim_px: np.ndarray  # (n, 2) each disc's rim point facing the arm, whole pixels
    arm_px: np.ndarray  # (4, 2) shoulder, elbow and wrist axes and the brush's centre, whole pixels
    arm_top_px: np.ndarray  # (4, 2) the same four points in the overhead view, whole pixels


def brush_face_m(data: mujoco.MjData) -> np.ndarray:
    """Centre of the brush's face (world): half the head's length along the tool axis."""
    head = data.body("brush_head")
    return head.xpos + BRUSH_HALF_LENGTH_M * head.xmat.reshape(3, 3)[:, 0]


def disc_rims_m(model: mujoco.MjModel) -> np.ndarray:
    """Each disc's rim point facing the arm's base, world, (n, 3)."""
    return np.array([disc.rim_facing()[0] for disc in discs_of(model)])


class GlobalCamera:
    """The global camera's frames at its frame rate, the last few kept (what the screen showed).

    A frame is recorded as the world points it shows (twin/camera_frames.py, also from the run
    loop's compiled ticks: `compiled_state`); its picture is made when the operator looks at it."""

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        params: OperatorParams,
        noise_px: float = 0.0,
        seed: int = 0,
    ):
        self.data = data
        # the pictures' noise ([reality] camera_noise_px: the operator does not know it): each point's
        # place off by a normal draw of this s.d. in each direction, before it is cut to whole pixels;
        # drawn from `seed` and the frame's number, so a frame is the same whenever it is made
        self.noise_px, self.seed = float(noise_px), int(seed)
        self.pinhole: Pinhole = camera_of(model, data, CAMERA, params.width_px, params.height_px)  # fixed to the world
        self.period_s = 1.0 / params.camera_fps
        still = self._noise(-1)  # the string does not move: one picture of it serves the run
        self.rim_px = self._pixels(self.pinhole.project(disc_rims_m(model)), still)
        # the discs' outlines, left and right ends: what the operator finds the string by
        ends = np.array([silhouette_ends_px(self.pinhole, disc) for disc in discs_of(model)])
        self.disc_ends_px = self._pixels(ends, still)
        self.overhead: Pinhole = camera_of(model, data, OVERHEAD, params.width_px, params.height_px)
        self.top_disc_ends_px = self._pixels(silhouette_ends_px(self.overhead, discs_of(model)[0]), still)
        body = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in ("brush_head", *ARM_POINTS)]
        self.body_ids = np.array(body, dtype=np.int64)
        self.site_ids = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "brush_tip")], dtype=np.int64)
        self.clock = np.array([0.0, self.period_s, 0.0])  # next frame due, period, frames taken
        self.rows = np.zeros((FRAMES_KEPT, row_size(len(self.body_ids), len(self.site_ids))))

    def _noise(self, frame: int) -> np.random.Generator | None:
        """The draws of frame number `frame` (-1: the picture of the string); None without noise."""
        return np.random.default_rng([self.seed, 2, frame + 1]) if self.noise_px > 0 else None

    def _pixels(self, uv: np.ndarray, noise: np.random.Generator | None) -> np.ndarray:
        """Picture coordinates as seen: the noise added, cut to whole pixels."""
        return np.floor(uv if noise is None else uv + noise.normal(0.0, self.noise_px, np.shape(uv)))

    def sight_string(self) -> Sighting:
        """The string as found in the picture (scenarios/sighting.py), the disc type being known."""
        radius, half = believed_disc_type()
        return sight_string(self.pinhole, self.disc_ends_px, self.overhead, self.top_disc_ends_px, radius, half)

    def capture(self, time_s: float) -> None:
        """Take a frame if one is due (called every control tick)."""
        d = self.data
        record_frame(self.clock, self.rows, self.body_ids, self.site_ids, d.xpos, d.xmat, d.site_xpos, time_s)

    def compiled_state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(clock, rows, body_ids, site_ids): what `record_frame` takes frames with."""
        return self.clock, self.rows, self.body_ids, self.site_ids

    @property
    def frames(self) -> list[Frame]:
        """The last FRAMES_KEPT frames, oldest first."""
        return [self._frame(i) for i in self._kept()]

    def _kept(self) -> range:
        # the numbers of the frames still in the ring, oldest first
        taken = int(self.clock[CLOCK_TAKEN])
        return range(max(0, taken - FRAMES_KEPT), taken)

    def _time_s(self, i: int) -> float:
        return float(self.rows[i % FRAMES_KEPT, 0])

    def _frame(self, i: int) -> Frame:
        """Frame number i, its picture made from the recorded points."""
        r = self.rows[i % FRAMES_KEPT]
        face = r[1:4] + BRUSH_HALF_LENGTH_M * r[4:7]  # brush_face_m of the recorded head
        points = np.array([face, r[7:10], r[10:13], r[13:16], r[16:19]])
        noise = self._noise(i)
        seen = self._pixels(self.pinhole.project(points), noise)
        from_above = self._pixels(self.overhead.project(points[1:]), noise)
        return Frame(time_s=float(r[0]), brush_px=seen[0], rim_px=self.rim_px, arm_px=seen[1:], arm_top_px=from_above)

    @property
    def next_frame_s(self) -> float:
        """When the next frame is due (`capture` takes it at a tick within 1e-9 s of it or after)."""
        return float(self.clock[CLOCK_NEXT_S]) - 1e-9

    def seen_from_s(self, latency_s: float, taken_after_s: float) -> float:
        """The earliest time `seen(now, latency_s, taken_after_s)` can give a frame, from the frames
        taken so far (math.inf: none of them; a later frame comes at `next_frame_s`)."""
        kept = self._kept()
        times = self.rows[np.arange(kept.start, kept.stop) % FRAMES_KEPT, 0]  # oldest first (asked every
        after = np.flatnonzero(times >= taken_after_s - 1e-9)  # tick of a wait: one array, not 64 floats)
        return float(times[after[0]]) + latency_s - 1e-9 if after.size else math.inf

    def seen(self, now_s: float, latency_s: float, taken_after_s: float) -> Frame | None:
        """The newest frame taken at or after `taken_after_s` that the operator has seen by now."""
        for i in reversed(self._kept()):
            t = self._time_s(i)
            if t + latency_s <= now_s + 1e-9:
                return self._frame(i) if t >= taken_after_s - 1e-9 else None
        return None


class Operator:
    """Corrects the brush's aim by what the camera shows (see the module's docstring)."""

    def __init__(self, model: mujoco.MjModel, camera: GlobalCamera, params: OperatorParams, rng: np.random.Generator):
        self.model, self.camera, self.params = model, camera, params
        self.rng = rng  # his reaction time varies from look to look
        self._latency_s = self._draw_latency()
        self.aim_offset_m = np.zeros(3)  # added to every brush target's tool-tip position (world x, z)
        self._last_move_m = np.zeros(3)  # the last change of the aim (taken back if the platform refuses it)
        self.looks = 0
        self.press_looks = 0  # corrections of the press on the disc under way
        self.last_miss_m = 0.0  # how far off the brush's face he last saw it (m)
        self.implausible = ""  # why his last look is not to be believed ('' : it is): he stops and backs off
        # why his last look saw the brush on a rim where it should stand clear ('': it did not), and how
        # far he draws it out along the rim's normal for it to stand where the target holds it
        self.on_rim = ""
        self.draw_out_m = 0.0
        self.drawn_out: list[int] = []  # the disc of each look that saw the brush on its rim
        self._last_set: dict[str, float] = {}  # the joints he set the belief of at his last look, as seen
        # joints he saw not move by a small move and left where they stand: (angle, band) per joint; a
        # target within the band of it is not sent again (`hold`), a larger move lets it go
        self.held: dict[str, tuple[float, float]] = {}
        # he finds the string in the picture first (its discs' outlines and the known disc type): the
        # plan is made for the string he found, and what a pixel is at the string is his scale
        self.sighting: Sighting = camera.sight_string()
        self.log: list[str] = [
            f"t = 0.00 s: string found: {len(self.sighting.discs)} discs, pitch {self.sighting.pitch_m * 100:.1f} cm, "
            f"top disc at ({', '.join(f'{v:.3f}' for v in self.sighting.discs[0].centre_m)}) m"
        ]

    @property
    def tolerance_m(self) -> float:
        """How near he places the brush: the scenario's tolerance, never finer than a pixel of his
        picture at the string (an error under a pixel he cannot see: at 160x120 a pixel is 2.5 cm,
        and chasing a 1 cm tolerance moved the brush a whole pixel at a time, 2 cm off the rim)."""
        return max(self.params.tolerance_m, self.sighting.m_per_px)

    @property
    def coarse(self) -> bool:
        """His picture's pixel at the string is coarser than the scenario's tolerance (320x240 and
        below with the shipped 1 cm): what he reads off it may be off by more than he places to."""
        return self.sighting.m_per_px > self.params.tolerance_m

    def picture_error_m(self, frame: Frame, disc: int, standoff_m: float) -> np.ndarray:
        """The face's error from where it should stand (world x, 0, z), as the picture shows it: the
        standoff is along the rim's outward normal of the disc as he found it."""
        scale = self.sighting.m_per_px
        du, dv = frame.brush_px - frame.rim_px[disc - 1]
        _, normal = self.sighting.discs[disc - 1].rim_facing()
        return np.array([du * scale - standoff_m * normal[0], 0.0, -dv * scale - standoff_m * normal[2]])

    def _draw_latency(self) -> float:
        return max(0.0, self.params.latency_s * (1.0 + LATENCY_SPREAD * (2.0 * self.rng.random() - 1.0)))

    def carrier_seen_m(self, frame: Frame) -> np.ndarray:
        """The brush's carrier (the last arm point), world, found from both views (`triangulate`)."""
        return triangulate(self.camera.pinhole, frame.arm_px[-1:], self.camera.overhead, frame.arm_top_px[-1:])[0]

    def read_pose(self, frame: Frame) -> dict[str, float]:
        """Drive angles of the joints as the pictures show them (rad): each link's pitch is its
        line's slope in the global view (v grows downwards); the base yaw is the bearing of the
        brush's carrier from the base axis (the arm works in a vertical plane through that axis,
        assets/arm.xml), the carrier placed by both views. The tool roll turns the round brush about
        its own axis: no picture shows it."""
        pitch = [
            math.atan2(-(b[1] - a[1]), b[0] - a[0]) for a, b in zip(frame.arm_px[:-1], frame.arm_px[1:], strict=True)
        ]
        upper, fore, tool = pitch
        carrier = self.carrier_seen_m(frame)
        yaw = math.atan2(carrier[1], carrier[0])
        return {"base_yaw": yaw, "shoulder_pitch": upper, "elbow_pitch": fore, "wrist_pitch": tool - fore}

    def reading_noise_rad(self, frame: Frame) -> dict[str, float]:
        """How far off an angle read from the pictures may be: REREAD_PX over each link's length in
        pixels; a drive angle that is a difference of two pitches takes the shorter link's; the base
        yaw, REREAD_PX of the overhead view at the carrier over the carrier's distance from the axis."""
        length = np.linalg.norm(np.diff(frame.arm_px, axis=0), axis=1)
        upper, fore, tool = (REREAD_PX / max(n, 1.0) for n in length)
        carrier = self.carrier_seen_m(frame)
        depth = float(-self.camera.overhead.camera_frame(carrier[None])[0, 2])
        yaw = REREAD_PX * self.camera.overhead.metres_per_px(depth) / max(float(np.hypot(*carrier[:2])), 0.05)
        return {"base_yaw": yaw, "shoulder_pitch": upper, "elbow_pitch": fore, "wrist_pitch": max(fore, tool)}

    def implausible_pose(self, seen: dict[str, float], believed: dict[str, float], disc: int, standoff_m: float) -> str:
        """Why the pose seen is too far from the platform's belief to be corrected where the brush
        stands ('' if it is not): a joint seen more than IMPLAUSIBLE_RAD off, or the brush's carrier,
        put by the arm's kinematics at the pose seen, further behind where the belief puts it, along
        the rim's normal, than the brush stands off the rim plus the plan's press (PRESS_M): going
        there again from where it is, the brush would move into the rim further than a press does."""
        joint = max(seen, key=lambda j: abs(seen[j] - believed[j]))
        off = seen[joint] - believed[joint]
        inwards, moved = 0.0, 0.0  # off the string (disc 0): no rim to go into
        if disc:
            _, normal = self.sighting.discs[disc - 1].rim_facing()
            move = carrier_m(self.model, believed) - carrier_m(self.model, {**believed, **seen})
            inwards = float(-move @ normal)
            moved = float(np.linalg.norm(move + inwards * normal))  # across the rim's normal
        # with a coarse picture, nearer the rim than the plan's clearance, a correction moving the
        # brush across the rim's normal further than it stands off the rim may be his misreading and
        # bring the head's side down on the rim's edge (160x120: an elbow re-read at 2 cm moved the
        # brush 4 cm, mostly down, 258 N on disc 1's top edge; one at 5 cm, 8 deg, 9 cm, 292 N). With
        # a sharp one such a correction is the arm's real sag (payload x1.1: the brush 3 cm low at
        # 2 cm), and made there as before
        near = self.coarse and standoff_m < CLEAR_M - 1e-9 and moved > standoff_m
        if abs(off) <= IMPLAUSIBLE_RAD and inwards <= standoff_m + PRESS_M and not near:
            return ""
        return (
            f"{joint} seen {math.degrees(off):+.1f} deg off the platform's belief, the brush to go "
            f"{inwards * 100:.1f} cm towards the rim it stands {standoff_m * 100:.0f} cm off"
            + (f" and {moved * 100:.1f} cm across it" if near else "")
        )

    def _seen_on_rim(self, frame: Frame, disc: int, standoff_m: float) -> bool:
        """His look shows the centre of the brush's face on `disc`'s rim or past it (along the rim's
        normal, as he found the disc) at a target that holds it clear (further off than touching
        distance, TOUCH_STANDOFF_M), at most DRAW_OUTS_PER_DISC times a disc: `on_rim` says so and
        `draw_out_m` is how far out along the normal it must go to stand `standoff_m` off. A brush on
        the rim where it should stand 5 cm off (disc 2, 160x120: a shoulder 7 deg off, unread under the
        picture's 5.7 deg, the head pushed in 3.4 cm, 37 N; seen 2.6 cm past the rim) is no drift to
        correct by the whole pose: sent again from there, the head's edge was dragged over the rim's
        (163-200 N); the move out is made first. Not the face's edge (`face_clear_m`): with the tool
        tilted 35-60 deg at the string 10 cm closer its edge is seen on the rim at a 4 cm standoff
        while the face stands 2.5-3 cm off. Nor the head's stroke: seen 0.5 cm for 3.4 at 160x120."""
        self.on_rim, self.draw_out_m = "", 0.0
        if not disc or not math.isfinite(standoff_m) or standoff_m <= TOUCH_STANDOFF_M + 1e-9:
            return False
        if self.drawn_out.count(disc) >= DRAW_OUTS_PER_DISC:
            return False
        _, normal = self.sighting.discs[disc - 1].rim_facing()
        out = float(self.picture_error_m(frame, disc, 0.0) @ normal)
        if out >= 0.0:
            return False
        self.on_rim = f"brush seen {-out * 100:.1f} cm past the rim it should stand {standoff_m * 100:.0f} cm off"
        self.draw_out_m = standoff_m - out
        self.drawn_out.append(disc)
        return True

    def swing_clear_m(self, carrier_m_: np.ndarray, yaw_to_rad: float) -> float:
        """How near the brush's face comes to the string he found (m, the least over its discs: out
        from each rim along the disc's plane; inf: it passes at no disc's height) when the arm turns
        about the base axis from where its carrier stands to `yaw_to_rad`, the carrier's distance from
        the axis and height kept. The face is taken BRUSH_HALF_LENGTH_M ahead of the carrier, out
        from the axis (the tool level, as the plan's home pose holds it); a disc counts where the
        head (its face's radius) reaches its shell's height, give or take his picture's pixel at the
        string (a 160x120 carrier was placed 1.4 cm low)."""
        radial, z = float(np.hypot(carrier_m_[0], carrier_m_[1])), float(carrier_m_[2])
        head = float(self.model.geom("brush").size[0])
        yaw_now = math.atan2(carrier_m_[1], carrier_m_[0])
        least = math.inf
        for yaw in np.linspace(yaw_now, yaw_to_rad, 41):
            face = np.array(
                [(radial + BRUSH_HALF_LENGTH_M) * math.cos(yaw), (radial + BRUSH_HALF_LENGTH_M) * math.sin(yaw), z]
            )
            for disc in self.sighting.discs:
                v = face - disc.centre_m
                along = float(v @ disc.axis)
                if abs(along) > disc.half_thickness_m + head + self.sighting.m_per_px:
                    continue
                least = min(least, float(np.linalg.norm(v - along * disc.axis)) - disc.radius_m)
        return least

    def review_swing(self, now_s: float, done_s: float, platform, yaw_to_rad: float) -> bool | None:
        """Look, before the plan's last move turns the arm back to `yaw_to_rad` from aside of the
        string, at where the brush's carrier stands (both views, `carrier_seen_m`: the pitches he
        reads off the global view are foreshortened this far out of its plane) and whether, turned
        back, its face would pass nearer the string than touching distance (`swing_clear_m`). The plan's
        home pose holds the face 5 cm off disc 5's rim: a shoulder left 7 deg short by the retreat
        put it 1 cm inside, and the turn back swept the head's side into the disc at 879 N (160x120).
        None: waiting for a picture; True: the carrier further out than the platform believes (the
        shoulder short): he sets the shoulder's belief by the carrier seen (the elbow and wrist as
        believed) and the target is sent again; False: clear (or out of looks): he turns it back."""
        frame = self.camera.seen(now_s, self._latency_s, done_s)
        if frame is None:
            return None
        self._latency_s = self._draw_latency()
        self.implausible, self.on_rim = "", ""
        carrier = self.carrier_seen_m(frame)
        clear = self.swing_clear_m(carrier, yaw_to_rad)
        believed = dict(zip(platform.joints, platform.predicted_angles(), strict=True))
        shoulder = self.shoulder_from_carrier(carrier, believed)
        noise = self.reading_noise_rad(frame)["shoulder_pitch"]
        near = clear < TOUCH_STANDOFF_M + self.sighting.m_per_px  # touching distance, and his pixel at the string
        if not near or self.looks >= MAX_LOOKS or abs(shoulder - believed["shoulder_pitch"]) <= noise:
            self.log.append(
                f"t = {now_s:.2f} s: final pose: brush to pass {clear * 100:.1f} cm clear of the string "
                f"turned back, after {self.looks} corrections: turned back"
            )
            self.looks = 0
            return False
        platform.reference("shoulder_pitch", shoulder)
        self.looks += 1
        self.log.append(
            f"t = {now_s:.2f} s: final pose: brush to pass {clear * 100:.1f} cm clear of the string turned back; "
            f"shoulder_pitch seen at {math.degrees(shoulder):.1f} deg by its carrier, platform believed "
            f"{math.degrees(believed['shoulder_pitch']):.1f} deg: pose re-read"
        )
        return True

    def shoulder_from_carrier(self, carrier_m_: np.ndarray, believed: dict[str, float]) -> float:
        """The shoulder's pitch (rad) that puts the brush's carrier where it is seen, the forearm's
        and the tool's pitch as believed: the upper arm's line from the shoulder to the elbow, the
        elbow found back from the carrier along the tool and the forearm (ik.arm_lengths)."""
        shoulder, _, fore, tool = arm_lengths(self.model)
        f, t = believed["elbow_pitch"], believed["elbow_pitch"] + believed["wrist_pitch"]
        radial = float(np.hypot(carrier_m_[0], carrier_m_[1])) - tool * math.cos(t) - fore * math.cos(f)
        z = float(carrier_m_[2]) - tool * math.sin(t) - fore * math.sin(f)
        return math.atan2(z - shoulder[2], radial - shoulder[0])

    def aimed(self, tip_m: np.ndarray, tilt_rad: float) -> dict[str, float]:
        """Drive angles for a brush target with the operator's aim applied (the tool tilted from
        `tilt_rad` where a joint would leave its range: he places the brush, not its tilt)."""
        return tip_drive_angles(self.model, tip_m + self.aim_offset_m, tilt_rad)

    def pressed(self, tip_m: np.ndarray, wrist_rad: float, tilt_rad: float) -> dict[str, float]:
        """Drive angles of the shoulder and elbow that put the brush at `tip_m` (his aim applied)
        with the wrist left at `wrist_rad`: he presses with the big joints and lets the tool's tilt
        follow the forearm (a few degrees over a press). The wrist pair is sized at its reducer's
        limit for the payload (DESIGN, "Sizing"): its small moves under load are the least exact
        of the arm's, 2-3 times the predicted at discs 1 and 7 (as-built, 0.6-0.8 MPa), enough to
        swing the head's side onto the rim (and a correction at 2 cm off it, 60 N). The tool's
        pitch is the forearm's plus the wrist's, so the planar IK is repeated with the tilt it
        gives (the 0.15 m tool is short against the 0.5 m links: a few rounds settle it to a
        micrometre), from the tool's pitch `tilt_rad`. ValueError if out of reach or range."""
        drive = tool_drive_angles(self.model, tip_m + self.aim_offset_m, tilt_rad)
        for _ in range(12):
            drive = tool_drive_angles(self.model, tip_m + self.aim_offset_m, drive["elbow_pitch"] + wrist_rad)
        drive["wrist_pitch"] = wrist_rad
        qpos = drive_to_qpos(drive)
        if joint := joint_out_of_range(self.model, qpos):
            raise ValueError(f"{joint} at {math.degrees(qpos[joint]):.1f} deg is out of its range")
        del drive["wrist_pitch"]
        return drive

    def press_error_m(self, frame: Frame, press_m: float) -> float:
        """How much further than `press_m` the brush's head is pushed into its carrier (m; negative:
        short), as the picture shows it: the head's face stands BRUSH_HALF_LENGTH_M ahead of the
        carrier (`brush_tip`, the last arm point) at rest and its stroke less in a press, along the
        tool's axis (the line from the wrist's axis to the carrier). The stroke is what the force
        is (the spring's), wherever on the face the rim bears: at disc 1, tilted 15 deg, the carrier
        stood 11 mm past the rim point with the head pushed 26 mm in (the face's lower half on it)."""
        scale = self.sighting.m_per_px
        wrist, carrier = frame.arm_px[-2], frame.arm_px[-1]
        axis = (carrier - wrist) / max(float(np.linalg.norm(carrier - wrist)), 1.0)
        ahead = float((frame.brush_px - carrier) @ axis) * scale
        return BRUSH_HALF_LENGTH_M - ahead - press_m

    def face_clear_m(self, frame: Frame, disc: int) -> float:
        """How far the brush's face stands clear of `disc`'s rim, as the picture shows it (m; 0 or
        less: on it): its centre's distance out along the rim's normal, less what the face's edge
        reaches ahead of its centre with the tool tilted from the normal (its radius, assets/arm.xml,
        times the tilt's sine: at disc 1, tilted 15 deg, 1.2 cm)."""
        _, normal = self.sighting.discs[disc - 1].rim_facing()
        out = float(self.picture_error_m(frame, disc, 0.0) @ normal)
        wrist, carrier = frame.arm_px[-2], frame.arm_px[-1]
        axis = np.array([carrier[0] - wrist[0], -(carrier[1] - wrist[1])])  # picture x, z
        inward = -np.array([normal[0], normal[2]])
        cos_tilt = float(axis @ inward) / max(float(np.linalg.norm(axis) * np.linalg.norm(inward)), 1e-12)
        return out - float(self.model.geom("brush").size[0]) * math.sqrt(max(0.0, 1.0 - cos_tilt**2))

    def review_press(self, now_s: float, done_s: float, disc: int, press_m: float) -> bool | None:
        """Look at the brush pressed into `disc` (the press finished at `done_s`). None: still
        waiting for a picture of it; True: the press is off by more than `tolerance_m` (his aim
        moved along the press by what he sees, at most MAX_PRESS_LOOKS times a disc: press again);
        False: pressed as planned (or out of looks)."""
        frame = self.camera.seen(now_s, self._latency_s, done_s)
        if frame is None:
            return None
        self._latency_s = self._draw_latency()
        error = self.press_error_m(frame, press_m)
        _, normal = self.sighting.discs[disc - 1].rim_facing()
        if press_m + error > self.tolerance_m and self.face_clear_m(frame, disc) > self.tolerance_m:
            # the head pushed into its carrier with the face clear of the rim: nothing can push it,
            # so the picture is misread (or the head jammed): he does not press again by it
            seen = (
                f"head seen pushed in {(press_m + error) * 100:.1f} cm, its face "
                f"{self.face_clear_m(frame, disc) * 100:.1f} cm clear of the rim"
            )
            self.log.append(f"t = {now_s:.2f} s: disc_{disc} {seen}: not believed, the operator backs out")
            self.press_looks = 0
            return False
        # the stroke is read as the distance between two points each cut to a whole pixel: with a picture
        # coarser than his tolerance (`coarse`) a reading is off by up to a pixel besides the error he
        # places to, so he corrects the press only past both (160x120: 5.1 cm). Pressed 4 cm in (42 N,
        # in band) a 160x120 picture showed 5.5 cm, and two corrections by it, each an out-and-in of the
        # shoulder, left the platform believing it 14 deg off and the brush on the rim at its back-off,
        # swept by the next move at 329 N
        limit = self.tolerance_m + (self.sighting.m_per_px if self.coarse else 0.0)
        if abs(error) <= limit or self.press_looks >= MAX_PRESS_LOOKS:
            self.log.append(
                f"t = {now_s:.2f} s: disc_{disc} head seen pushed in {(press_m + error) * 100:.1f} cm "
                f"after {self.press_looks} corrections: pressed"
            )
            self.press_looks = 0
            return False
        self.press_looks += 1
        move = -error * normal  # along the rim's normal, as he found the disc: out where it is pushed in too far
        self.aim_offset_m -= move
        self._last_move_m = move
        self.log.append(
            f"t = {now_s:.2f} s: disc_{disc} head seen pushed in {(press_m + error) * 100:.1f} cm "
            f"for {press_m * 100:.1f}: press moved {-error * 100:+.1f} cm"
        )
        return True

    def hold(self, drive: dict[str, float]) -> dict[str, float]:
        """`drive` with each joint he left where it stands (`held`) kept there where the target is
        within the band of it: a move the platform did not make once it does not make again (the
        base yaw, 2 deg off, re-read and sent back at every target, 60 times a run with the friction
        1.3 times the files', took 40 s). A target further off is a real move: he lets the joint go."""
        out = dict(drive)
        for joint, (angle, band) in list(self.held.items()):
            if joint not in out:
                continue
            if abs(out[joint] - angle) <= band:
                out[joint] = angle
            else:
                del self.held[joint]
        return out

    def take_back(self) -> None:
        """The platform refused the last aim (out of a joint's range): the arm did not move, and
        the same error seen again must not be added twice."""
        self.aim_offset_m += self._last_move_m
        self._last_move_m = np.zeros(3)

    def review_due_s(self, done_s: float) -> float:
        """The earliest time `review(now, done_s, ...)` (or `review_press`) can do more than wait for
        a picture: his latency after the first frame taken since `done_s`, of the frames so far or,
        if none, of the camera's next (taken at its due time at the earliest, `next_frame_s`)."""
        latency = self._latency_s
        return min(self.camera.seen_from_s(latency, done_s), self.camera.next_frame_s + latency - 1e-9)

    def review(
        self, now_s: float, done_s: float, disc: int, standoff_m: float, platform, aim: bool = True
    ) -> bool | None:
        """Look at the brush standing off `disc` (0: the arm at a pose off the string, the plan's
        last), and set the platform's belief of the pose to the picture's
        (`platform.reference(joint, angle)`). None: still waiting for a picture of the arm at rest;
        True: the belief was reset or the aim moved, go there again; False: close enough (or out of
        looks). With `aim` False (the brush well clear of the string, on its way) he only resets the
        belief: placing the brush to a centimetre matters before a press."""
        frame = self.camera.seen(now_s, self._latency_s, done_s)
        if frame is None:
            return None
        self._latency_s = self._draw_latency()
        self._last_move_m = np.zeros(3)  # a new look: the arm went where the last aim sent it
        self.implausible = ""
        noise = self.reading_noise_rad(frame)
        # a joint whose reading may be off by more than UNREADABLE_RAD he does not read: he leaves
        # the platform's belief of it and places the brush by what he sees of the brush itself
        seen_pose = {j: a for j, a in self.read_pose(frame).items() if noise[j] <= UNREADABLE_RAD}
        believed = dict(zip(platform.joints, platform.predicted_angles(), strict=True))
        if self._seen_on_rim(frame, disc, standoff_m):
            # the brush on the rim where it should stand clear: sending the pose again from there
            # drags the head's edge along the rim (the shoulder's 7 deg re-read at disc 2's 12 cm
            # clearance, 160x120: 200 N). He sets the belief to what he sees and draws the brush
            # straight out first (scenarios/task.py, DRAWING_OUT), then looks again
            for joint, angle in seen_pose.items():
                platform.reference(joint, angle)
            self._last_set = {}
            self.log.append(f"t = {now_s:.2f} s: disc_{disc}: {self.on_rim}: pose re-read, the operator draws it out")
            return True
        worst = max(seen_pose, key=lambda j: abs(seen_pose[j] - believed[j]) / noise[j], default="")
        off = [j for j in seen_pose if abs(seen_pose[j] - believed[j]) > noise[j]]
        # a joint he set last time and sees where it was, the platform having been sent to correct
        # it, does not move by so little (a small move under friction is a fraction of the one
        # commanded): he sets the belief and lets the joint be, instead of sending it again and again
        # (2 deg of base yaw re-read 116 times with friction 1.3 times the files')
        stuck = [j for j in off if j in self._last_set and abs(seen_pose[j] - self._last_set[j]) <= noise[j]]
        if not off:
            self._last_set = {}
        elif len(stuck) == len(off):
            targets = dict(zip(platform.joints, platform.target_angles(), strict=True))
            for joint, angle in seen_pose.items():
                platform.reference(joint, angle)
            for joint in set(stuck) & set(HELD):
                self.held[joint] = (seen_pose[joint], abs(targets[joint] - seen_pose[joint]) + noise[joint])
            self._last_set = {}
            self.log.append(
                f"t = {now_s:.2f} s: {_where(disc)}: {', '.join(stuck)} seen where set last time: the platform does "
                "not move it so little; belief set, left there"
            )
        elif self.looks < MAX_LOOKS and off:
            self.implausible = self.implausible_pose(seen_pose, believed, disc, standoff_m)
            for joint, angle in seen_pose.items():
                platform.reference(joint, angle)
            self._last_set = {j: seen_pose[j] for j in off}
            self.looks += 1
            self.log.append(
                f"t = {now_s:.2f} s: {_where(disc)}: {worst} seen at {math.degrees(seen_pose[worst]):.1f} deg, "
                f"platform believed {math.degrees(believed[worst]):.1f} deg: pose re-read"
                + (f"; {self.implausible}: the operator stops" if self.implausible else "")
            )
            return True
        if not aim:
            self.looks = 0
            return False
        error = self.picture_error_m(frame, disc, standoff_m)
        miss = float(np.hypot(error[0], error[2]))
        self.last_miss_m = miss
        if miss <= self.tolerance_m or self.looks >= MAX_LOOKS:
            aimed = ""
            if miss > self.tolerance_m:
                # out of looks: he does not press blind, the press is aimed by what he last saw
                self.aim_offset_m -= error
                self._last_move_m = error
                aimed = " aimed by it"
            self.log.append(
                f"t = {now_s:.2f} s: disc_{disc} seen {miss * 100:.1f} cm off its {standoff_m * 100:.0f} cm "
                f"standoff after {self.looks} corrections: placed{aimed}"
            )
            self.looks = 0
            return False
        self.looks += 1
        self.aim_offset_m -= error
        self._last_move_m = error
        _, normal = self.sighting.discs[disc - 1].rim_facing()
        across = float(np.linalg.norm(error - (error @ normal) * normal))
        if self.coarse and standoff_m <= TOUCH_STANDOFF_M + 1e-9 and across > standoff_m + self.tolerance_m:
            # an aim moved across the rim's normal further than the brush stands off the rim, and more
            # than the picture's pixel beyond it, is not moved there: he backs off and comes in again
            # by it (5 cm down at 2 cm off disc 1, 160x120); a pixel's move (2.5 cm there) he makes
            self.implausible = f"seen {across * 100:.1f} cm aside at {standoff_m * 100:.0f} cm from the rim"
        self.log.append(
            f"t = {now_s:.2f} s: disc_{disc} seen {miss * 100:.1f} cm off "
            f"(x {error[0] * 100:+.1f}, z {error[2] * 100:+.1f} cm): aim moved"
            + (f"; {self.implausible}: the operator stops" if self.implausible else "")
        )
        return True


def _where(disc: int) -> str:
    """What a look is at, in the log: a disc, or the plan's final pose."""
    return f"disc_{disc}" if disc else "final pose"
