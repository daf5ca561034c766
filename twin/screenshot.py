"""A screenshot of a recording as the real rerun viewer opens it: what a user sees first.

    python -m twin.screenshot RUN.rrd OUT.png [--size 1600x1000]

Runs the viewer installed with rerun-sdk (`rerun FILE --screenshot-to OUT --window-size WxH`),
which draws the recording's default blueprint and quits. On a machine without a display it runs
inside a virtual X server (`xvfb-run`); without a GPU the viewer needs a software Vulkan driver
(Debian/Ubuntu: `apt-get install xvfb mesa-vulkan-drivers`, which gives llvmpipe). The viewer
takes 30-90 s per screenshot on a 2-core machine without a GPU.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from pathlib import Path

from twin_plumbing.errors import UserError

VULKAN_ICD_DIRS = ("/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d")


def missing_requirements() -> str:
    """Why the viewer cannot take a screenshot here ("" when it can)."""
    if shutil.which("rerun") is None and not Path(sys.executable).with_name("rerun").exists():
        return "the rerun viewer (rerun-sdk's `rerun` executable) is not installed"
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")) and shutil.which("xvfb-run") is None:
        return "no display and no xvfb-run (apt-get install xvfb)"
    if not any(Path(d).is_dir() and any(Path(d).glob("*.json")) for d in VULKAN_ICD_DIRS):
        return "no Vulkan driver (apt-get install mesa-vulkan-drivers for the software one)"
    return ""


def screenshot(rrd: Path, out: Path, size: str = "1600x1000", timeout_s: float = 300.0) -> Path:
    """Open `rrd` in the rerun viewer and save what it shows to `out` (PNG). Raises UserError
    when the viewer cannot run here or does not write the picture."""
    reason = missing_requirements()
    if reason:
        raise UserError(f"cannot take a screenshot of {rrd}: {reason}")
    if not Path(rrd).is_file():
        raise UserError(f"{rrd}: no such recording")
    exe = shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.unlink(missing_ok=True)
    w, _, h = size.partition("x")
    cmd = [exe, str(rrd), "--screenshot-to", str(out), "--window-size", size]
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        cmd = ["xvfb-run", "-a", "-s", f"-screen 0 {int(w) + 64}x{int(h) + 64}x24"] + cmd
    # no usage analytics from a headless screenshot
    env = dict(os.environ, RERUN_ANALYTICS="0", XDG_RUNTIME_DIR=os.environ.get("XDG_RUNTIME_DIR", "/tmp"))
    try:
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        raise UserError(f"the rerun viewer took more than {timeout_s:.0f} s to draw {rrd}") from None
    if not out.is_file():
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
        raise UserError(f"the rerun viewer wrote no screenshot of {rrd} (exit {proc.returncode}): {' / '.join(tail)}")
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m twin.screenshot", description=__doc__.splitlines()[0])
    parser.add_argument("rrd", type=Path, help="a recording (.rrd) from `twin run --rrd` or `twin replay`")
    parser.add_argument("out", type=Path, help="the PNG to write")
    parser.add_argument(
        "--size", default="1600x1000", help="viewer window size in logical points, WxH (default: 1600x1000)"
    )
    args = parser.parse_args(argv)
    try:
        print(screenshot(args.rrd, args.out, args.size))
    except UserError as e:
        print(f"twin.screenshot: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
