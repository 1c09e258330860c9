"""Draw what an arm did, from a recording: ``python -m rtcf_examples.render_arm
RECORDING.mcap --render DIR``.

The joint positions recorded on ``--topic`` (default ``/arm/position``, what arm.launch's
hardware interface measured) are set into the MuJoCo model one frame at a time and
drawn through ``mujoco.Renderer`` into ``DIR/frame_00000.png``..., and
``DIR/arm.gif``. Rendering happens here, after the run, never in the loop; the same
works for a recording of a real arm whose driver wrote the same topic. The recording is
read with :mod:`rtcf.recording`.

Needs ``pip install 'rtcf[mujoco,record]'`` and an OpenGL that works without a
display: EGL (Debian: ``apt install libegl1 libegl-mesa0``, the default here) or OSMesa
(``apt install libosmesa6``, with ``MUJOCO_GL=osmesa``).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any

from rtcf import RtcfError
from rtcf.recording import Series, read


def positions(recording: str, topic: str) -> Series | None:
    """The joint positions on ``topic`` over time (one row per message), or None when
    the recording has no message on it."""
    rec = read(recording, [topic])
    return rec.series(topic) if topic in rec.messages else None


def render(
    samples: Series,
    directory: Path,
    *,
    model_path: str,
    fps: float = 15.0,
    width: int = 480,
    height: int = 360,
) -> list[Path]:
    """Frames at ``fps`` (the latest sample at each frame's time, from the first
    sample's) as PNGs and one GIF."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    import mujoco
    from PIL import Image

    model = mujoco.MjModel.from_xml_path(model_path)
    data = mujoco.MjData(model)
    renderer = mujoco.Renderer(model, height, width)
    camera = "view" if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "view") >= 0 else -1
    directory.mkdir(parents=True, exist_ok=True)
    frames: list[Any] = []
    paths: list[Path] = []
    times = (samples.t_ns - samples.t_ns[0]) * 1e-9
    end = times[-1]
    k = 0
    for n in range(int(end * fps) + 1):
        t = n / fps
        while k + 1 < len(times) and times[k + 1] <= t:
            k += 1
        data.qpos[:] = samples.values[k]
        mujoco.mj_forward(model, data)
        renderer.update_scene(data, camera=camera)
        image = Image.fromarray(renderer.render())
        path = directory / f"frame_{n:05d}.png"
        image.save(path)
        paths.append(path)
        frames.append(image)
    frames[0].save(directory / "arm.gif", save_all=True, append_images=frames[1:],
                   duration=round(1000 / fps), loop=0)
    return paths


def main(argv: list[str] | None = None) -> int:
    from ._arm import shipped_model

    parser = argparse.ArgumentParser(
        prog="python -m rtcf_examples.render_arm", description=__doc__.split("\n\n")[0])
    parser.add_argument("recording", metavar="RECORDING.mcap")
    parser.add_argument("--render", metavar="DIR", required=True,
                        help="where the PNG frames and arm.gif go")
    parser.add_argument("--topic", default="/arm/position")
    parser.add_argument("--model", default="", help="MJCF file (default: the shipped arm)")
    parser.add_argument("--fps", type=float, default=15.0)
    args = parser.parse_args(argv)
    prog = "render_arm"
    os.environ.setdefault("MUJOCO_GL", "egl")  # read when mujoco is imported: first
    try:
        import mujoco  # noqa: F401
    except ImportError:
        print(f"{prog}: error: needs the mujoco package: pip install 'rtcf[mujoco]'",
              file=sys.stderr)
        return 1
    try:
        samples = positions(args.recording, args.topic)
    except RtcfError as exc:  # missing, not an MCAP file, no mcap packages: one line
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 1
    if samples is None:
        print(f"{prog}: error: {args.recording} has no messages on {args.topic}; record it "
              "with rtcf launch ... --record FILE.mcap", file=sys.stderr)
        return 1
    try:
        paths = render(samples, Path(args.render), model_path=args.model or shipped_model(),
                       fps=args.fps)
    except Exception as exc:  # an OpenGL that cannot start: say which and what to install
        print(f"{prog}: error: rendering with MUJOCO_GL={os.environ.get('MUJOCO_GL')} "
              f"failed: {type(exc).__name__}: {exc}; install EGL (apt install libegl1 "
              "libegl-mesa0) or OSMesa (apt install libosmesa6, MUJOCO_GL=osmesa)",
              file=sys.stderr)
        return 1
    print(f"{prog}: wrote {len(paths)} frames and arm.gif to {args.render}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
