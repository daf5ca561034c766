"""Frames of a scene camera for a recording, rendered offscreen in a process of its own.

The paper's operators steer by a global camera on the arm's platform; a recording shows that view
beside the 3D scene. MuJoCo picks its GL backend (MUJOCO_GL=egl or osmesa) once, when it is
imported, and the run's process has imported it long before, usually with none; so the frames
are rendered by `python -m twin.camera` started with the backend set (DESIGN "Headless pictures").
The run queues body poses and goes on; a worker thread hands them to the child (pickled) and
gathers the JPEG frames, which the run collects at its next batch or at close; so the run never
waits for the renderer except at the very end.

    cam = CameraProcess(model)               # starts at once; `cam.error` says if GL failed
    cam.request(times, body_pos, body_quat)  # poses of bodies 1.. (Telemetry order)
    for t, jpeg in cam.collect(): ...
    for t, jpeg in cam.close(): ...          # waits for the frames still being rendered
"""

from __future__ import annotations

import contextlib
import io
import os
import queue
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

import mujoco
import numpy as np
from PIL import Image

from twin import worker
from twin.camera_pose import FRAME_HEIGHT, FRAME_WIDTH
from twin.model import has_camera
from twin.render import PoseRenderer

JPEG_QUALITY = 85  # a 480x360 frame in ~25 KB instead of 518 KB raw


class CameraProcess:
    """A child process rendering `camera` of `model` at given body poses, as JPEG bytes.

    A worker thread starts the child (trying the GL backends in turn), hands it each request and
    reads back its frames; the run only queues requests and collects frames. If no backend
    renders, or the child dies, `error` says why and later requests are dropped.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        camera: str = "global_view",
        width: int = FRAME_WIDTH,
        height: int = FRAME_HEIGHT,
        backends: tuple[str, ...] | None = None,
    ):
        self._dir = tempfile.TemporaryDirectory(prefix="twin-camera-")
        self._mjb = Path(self._dir.name) / "model.mjb"
        mujoco.mj_saveModel(model, str(self._mjb), None)  # the exact compiled model, no XML paths needed
        self._args = [camera, str(width), str(height)]
        self._backends = backends or ((os.environ["MUJOCO_GL"],) if "MUJOCO_GL" in os.environ else ("egl", "osmesa"))
        self.backend: str | None = None
        self.error: str | None = None
        self._requests: queue.Queue = queue.Queue()
        self._frames: list[tuple[float, bytes]] = []
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._work, name="camera frames", daemon=True)
        self._thread.start()

    def _start(self) -> subprocess.Popen | None:
        tried = []
        for backend in self._backends:
            env = dict(os.environ, MUJOCO_GL=backend, PYOPENGL_PLATFORM=backend)
            err_path = Path(self._dir.name) / f"stderr-{backend}.txt"
            with open(err_path, "wb") as err:
                proc = worker.start("twin.camera", [str(self._mjb), *self._args], env=env, stderr=err)
            if proc.stdout.readline().strip() == b"ready":
                self.backend = backend
                return proc
            proc.kill()
            proc.wait()
            lines = err_path.read_text(errors="replace").strip().splitlines()
            tried.append(f"MUJOCO_GL={backend}: {lines[-1] if lines else f'exit code {proc.returncode}'}")
        self.error = "offscreen rendering failed (" + "; ".join(tried) + ")"
        return None

    def _work(self) -> None:
        proc = self._start()
        while True:
            req = self._requests.get()
            if req is None:
                break
            if proc is None:
                continue
            try:
                worker.send(proc.stdin, req)
                batch = worker.receive(proc.stdout)
            except worker.LOST as e:
                self.error = f"the camera process ended ({type(e).__name__})"
                proc.kill()
                proc.wait()
                proc = None
                continue
            with self._lock:
                self._frames.extend(batch)
        if proc is not None:
            with contextlib.suppress(OSError):
                proc.stdin.close()
            proc.wait()

    def request(self, times: np.ndarray, body_pos: np.ndarray, body_quat_wxyz: np.ndarray) -> None:
        """Ask for one frame per time, of the bodies at these poses; returns at once."""
        if len(times):
            self._requests.put((np.asarray(times), np.asarray(body_pos), np.asarray(body_quat_wxyz)))

    def collect(self) -> list[tuple[float, bytes]]:
        """The frames rendered so far, as (time, JPEG bytes)."""
        with self._lock:
            out, self._frames = self._frames, []
        return out

    def close(self) -> list[tuple[float, bytes]]:
        """Wait for the frames still being rendered; returns them."""
        self._requests.put(None)
        self._thread.join()
        self._dir.cleanup()
        return self.collect()


class FrameFeed:
    """Frames of `camera` at `fps` per simulated second for the recorders of one run: from each
    batch of telemetry it asks one CameraProcess for the first sample at or after every 1/fps
    tick. Recorders may share a feed (a run with both logs renders each frame once): asking
    twice for the same batch asks nothing more, and each recorder reads the frames by its own
    count (`frames_from`)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        fps: float,
        camera: str = "global_view",
        width: int = FRAME_WIDTH,
        height: int = FRAME_HEIGHT,
    ):
        self.fps = float(fps)
        self._next_t = 0.0
        self._frames: list[tuple[float, bytes]] = []
        self._done = False
        # a model without the camera (the wrist rig) has no frames to give, and nothing to say
        self.camera = None
        if has_camera(model, camera):
            self.camera = CameraProcess(model, camera=camera, width=width, height=height)

    @property
    def error(self) -> str | None:
        """Why frames the model has a camera for could not be rendered (None: they were)."""
        return self.camera.error if self.camera else None

    def request(self, telemetry, start: int) -> None:
        """Queue the frames due among telemetry samples `start`..; returns at once."""
        if self.camera is None:
            return
        times = telemetry.column("time_s", start)
        keep = []
        for k, t in enumerate(times):
            if t + 1e-9 >= self._next_t:
                self._next_t = (np.floor(t * self.fps + 1e-9) + 1) / self.fps
                keep.append(k)
        if keep:
            pos, quat = telemetry.column("body_pos_m", start), telemetry.column("body_quat_wxyz", start)
            self.camera.request(times[keep], pos[keep], quat[keep])

    def frames_from(self, k: int, wait: bool = False) -> list[tuple[float, bytes]]:
        """Frames k.. of those rendered so far, as (time, JPEG bytes) in the order rendered; with
        `wait`, of all of them (this waits for the last and ends the camera process)."""
        if self.camera is not None and not self._done:
            if wait:
                self._done = True
                self._frames += self.camera.close()
            else:
                self._frames += self.camera.collect()
        return self._frames[k:]


def _serve(argv: list[str]) -> None:
    """The camera process: `python -m twin.camera MODEL.mjb CAMERA WIDTH HEIGHT`."""
    model = mujoco.MjModel.from_binary_path(argv[0])
    # a software GL's costs, measured at 480x360: 82 ms a frame as the model asks, 14 without
    # shadows and reflections (PoseRenderer plain), 7.7 without 4x multisampling, 5.1 with 12
    # slices a cylinder instead of 28; an operator's view, not a README picture
    model.vis.quality.offsamples = 0
    model.vis.quality.numslices = 12
    renderer = PoseRenderer(model, camera=argv[1], width=int(argv[2]), height=int(argv[3]), plain=True)
    out = sys.stdout.buffer
    out.write(b"ready\n")
    out.flush()
    try:
        for times, pos, quat in worker.requests(sys.stdin.buffer):
            batch = []
            for t, p, q in zip(times, pos, quat, strict=True):
                buf = io.BytesIO()
                Image.fromarray(renderer.render(p, q)).save(buf, format="JPEG", quality=JPEG_QUALITY)
                batch.append((float(t), buf.getvalue()))
            worker.send(out, batch)
    finally:
        renderer.close()


if __name__ == "__main__":
    _serve(sys.argv[1:])
