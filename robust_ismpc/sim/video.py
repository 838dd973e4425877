"""Offscreen video of a MuJoCo run: frames from ``mujoco.Renderer``, mp4 through imageio; or the
interactive viewer (``ismpc run --viewer``).

Each frame carries a small overlay (:func:`draw_overlay`): the simulated time, the controller, and
while an external force acts on the robot an arrow in its direction as the camera sees it. The
mp4 is written to a hidden temporary file and renamed when the recorder closes (also after
Ctrl-C), so a killed run leaves no half-written ``video.mp4`` behind.

Offscreen rendering needs an OpenGL backend chosen with the ``MUJOCO_GL`` environment variable
*before mujoco is imported* (mujoco picks its GL context class at import). On a headless Linux
machine ``MUJOCO_GL=egl`` works with the Debian packages
``libegl1 libegl-mesa0 libgl1-mesa-dri libopengl0`` (Mesa's software rasteriser);
:mod:`robust_ismpc.robots` sets that default when it is imported before mujoco on a Linux machine
without display. The mp4 encoder is the ffmpeg binary shipped in the ``imageio-ffmpeg`` wheel.
"""

from __future__ import annotations

import copy
import logging
import os
import time
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from ..exceptions import ParameterError
from ..io import temporary_path

logger = logging.getLogger("robust_ismpc")


def configure_offscreen_gl(backend: str | None = None) -> str:
    """Choose the OpenGL backend for offscreen rendering (sets ``MUJOCO_GL``).

    Parameters
    ----------
    backend : str, optional
        ``"egl"``, ``"osmesa"`` or ``"glfw"``; default: keep ``MUJOCO_GL`` if set, else ``"egl"``
        when there is no ``DISPLAY``, else ``"glfw"``.

    Returns
    -------
    str
        The backend requested. It only takes effect if mujoco has not been imported yet; a
        warning is logged otherwise.
    """
    import sys

    before = os.environ.get("MUJOCO_GL")
    if backend is not None:
        if backend not in ("egl", "osmesa", "glfw"):
            raise ParameterError(f"backend must be egl, osmesa or glfw, got {backend!r}")
        os.environ["MUJOCO_GL"] = backend
    elif "MUJOCO_GL" not in os.environ:
        os.environ["MUJOCO_GL"] = "glfw" if os.environ.get("DISPLAY") else "egl"
    if os.environ["MUJOCO_GL"] != before and "mujoco" in sys.modules:
        logger.warning("MUJOCO_GL set to %s after mujoco was imported: it has no effect", os.environ["MUJOCO_GL"])
    return os.environ["MUJOCO_GL"]


@dataclass(frozen=True)
class VideoSettings:
    """What and how to record.

    Attributes
    ----------
    path : Path
        Output ``.mp4`` file.
    fps : int
        Frames per second of the video (simulated time) [1/s].
    width, height : int
        Frame size [pixel] (at most the model's offscreen buffer, 640 x 480 by default).
    distance_m, azimuth_deg, elevation_deg : float
        Tracking camera placement relative to the tracked body.
    track_body : str or None
        Body followed by the camera; None means the robot's root body.
    label : str
        Shown in the overlay next to the time (e.g. the controller).
    shadows, reflections, multisampling : bool
        Costly effects, off by default: with Mesa's software rasteriser a 640 x 480 G1 frame
        renders at about 23 frames/s without them and 4 frames/s with all three.
    """

    path: Path
    fps: int = 30
    width: int = 640
    height: int = 480
    distance_m: float = 2.5
    azimuth_deg: float = 135.0
    elevation_deg: float = -15.0
    track_body: str | None = None
    label: str = ""
    shadows: bool = False
    reflections: bool = False
    multisampling: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", Path(self.path))
        if self.path.suffix.lower() != ".mp4":
            raise ParameterError(f"VideoSettings.path must end with .mp4, got {str(self.path)!r}")
        for name in ("fps", "width", "height"):
            value = getattr(self, name)
            if not isinstance(value, int) or value <= 0:
                raise ParameterError(f"VideoSettings.{name} must be a positive integer, got {value!r}")
        if not self.distance_m > 0:
            raise ParameterError(f"VideoSettings.distance_m must be > 0, got {self.distance_m!r}")


class VideoRecorder:
    """Render frames of a scene with a tracking camera and write them to an mp4 file.

    Parameters
    ----------
    model : mujoco.MjModel
        Scene model.
    settings : VideoSettings
    default_track_body : str
        Body tracked when ``settings.track_body`` is None.

    Notes
    -----
    Use as a context manager or call :meth:`close`. ``render_time_s`` accumulates the rendering
    wall time; :attr:`frames_per_second` is the rendering throughput.
    """

    def __init__(self, model: mujoco.MjModel, settings: VideoSettings, default_track_body: str) -> None:
        import imageio.v2 as imageio  # only needed when recording

        configure_offscreen_gl()
        self.settings = settings
        width = min(settings.width, int(model.vis.global_.offwidth))
        height = min(settings.height, int(model.vis.global_.offheight))
        if (width, height) != (settings.width, settings.height):
            logger.warning("video frame size reduced to %dx%d (model offscreen buffer)", width, height)
        render_model = copy.deepcopy(model)  # the visual settings below must not leak into the scene
        if not settings.multisampling:
            render_model.vis.quality.offsamples = 0
        if not settings.shadows:
            render_model.vis.quality.shadowsize = 0
        self._renderer = mujoco.Renderer(render_model, height=height, width=width)
        self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = int(settings.shadows)
        self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = int(settings.reflections)
        name = settings.track_body or default_track_body
        body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        if body_id < 0:
            raise ParameterError(f"video track body {name!r} not found in the model")
        cam = mujoco.MjvCamera()
        cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING
        cam.trackbodyid = body_id
        cam.distance = settings.distance_m
        cam.azimuth = settings.azimuth_deg
        cam.elevation = settings.elevation_deg
        self._camera = cam
        settings.path.parent.mkdir(parents=True, exist_ok=True)
        self._partial_path = temporary_path(settings.path)
        self._writer = imageio.get_writer(
            str(self._partial_path), fps=settings.fps, codec="libx264", quality=7, macro_block_size=8
        )
        self.frame_count = 0
        self.render_time_s = 0.0
        self._next_frame_t_s = 0.0

    def due(self, t_s: float) -> bool:
        """True when a frame is due at simulated time ``t_s`` [s]."""
        return t_s + 1e-9 >= self._next_frame_t_s

    def capture(self, data: mujoco.MjData) -> np.ndarray:
        """Render the current state and append it to the video; returns the frame (H, W, 3) uint8."""
        start = time.perf_counter()
        self._renderer.update_scene(data, camera=self._camera)
        frame = draw_overlay(self._renderer.render(), data, self.settings.label, self._camera)
        self._writer.append_data(frame)
        self.render_time_s += time.perf_counter() - start
        self.frame_count += 1
        self._next_frame_t_s += 1.0 / self.settings.fps
        return frame

    def capture_if_due(self, data: mujoco.MjData) -> None:
        """Capture a frame if one is due at ``data.time``."""
        if self.due(data.time):
            self.capture(data)

    @property
    def frames_per_second(self) -> float:
        """Rendering throughput (frames per wall-clock second, encoding included)."""
        return self.frame_count / self.render_time_s if self.render_time_s > 0 else 0.0

    def close(self) -> None:
        """Finish the mp4 file (renamed from its temporary name) and free the renderer."""
        if self._writer is not None:
            writer, self._writer = self._writer, None
            try:
                writer.close()
                os.replace(self._partial_path, self.settings.path)
            finally:
                self._partial_path.unlink(missing_ok=True)
                self._renderer.close()
            logger.info("wrote %d frames to %s", self.frame_count, self.settings.path)

    def __enter__(self) -> VideoRecorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _applied_force_n(data: mujoco.MjData) -> np.ndarray:
    """Sum of the external forces on all bodies (``xfrc_applied``), world frame [N], shape (3,)."""
    return np.asarray(data.xfrc_applied)[:, :3].sum(axis=0)


def draw_overlay(frame: np.ndarray, data: mujoco.MjData, label: str, camera: mujoco.MjvCamera,
                 min_force_n: float = 0.5) -> np.ndarray:
    """Write the time and ``label`` in the top-left corner of ``frame`` and, while an external
    force acts, an arrow from the image centre (the tracked body) in the force's direction as
    seen by ``camera``, with its magnitude. Returns a new (H, W, 3) uint8 frame (Pillow, which
    imageio requires, draws)."""
    from PIL import Image, ImageDraw

    image = Image.fromarray(np.ascontiguousarray(frame))
    draw = ImageDraw.Draw(image)
    text = f"t = {data.time:5.2f} s" + (f"   {label}" if label else "")
    draw.rectangle((4, 4, 12 + 6 * len(text), 20), fill=(0, 0, 0))
    draw.text((8, 7), text, fill=(255, 255, 255))
    force = _applied_force_n(data)
    magnitude = float(np.hypot(force[0], force[1]))
    if magnitude >= min_force_n:
        az, el = np.radians(camera.azimuth), np.radians(camera.elevation)
        right = np.array([np.sin(az), -np.cos(az)])
        forward = np.array([np.cos(az), np.sin(az)])
        direction = np.array([force[:2] @ right, np.sin(el) * (force[:2] @ forward)])  # image x right, y down
        norm = float(np.hypot(*direction))
        if norm > 1e-9:
            height, width = frame.shape[:2]
            centre = np.array([width / 2, height / 2])
            tip = centre + direction / norm * 0.18 * min(width, height)
            colour = (230, 40, 40)
            draw.line((*centre, *tip), fill=colour, width=4)
            back = -direction / norm * 12
            side = np.array([-back[1], back[0]]) * 0.5
            draw.polygon([tuple(tip), tuple(tip + back + side), tuple(tip + back - side)], fill=colour)
            draw.text((tip[0] + 6, tip[1] - 6), f"{magnitude:.0f} N", fill=colour)
    return np.asarray(image)


def check_viewer() -> None:
    """Raise ParameterError unless an interactive viewer can open (a display is set)."""
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise ParameterError(
            "--viewer needs a display (neither DISPLAY nor WAYLAND_DISPLAY is set); on a machine "
            "without one, record the run with --video instead"
        )


class ViewerSink:
    """MuJoCo's passive interactive viewer, fed like a :class:`VideoRecorder` (``due``,
    ``capture``, ``close``) and paced to real time. Closing its window stops the run as if
    Ctrl-C had been pressed."""

    def __init__(self, model: mujoco.MjModel, fps: int = 60) -> None:
        self._model = model
        self._period_s = 1.0 / fps
        self._handle = None
        self._next_frame_t_s = 0.0
        self._start: tuple[float, float] | None = None
        self.frame_count = 0
        self.render_time_s = 0.0

    def due(self, t_s: float) -> bool:
        return t_s + 1e-9 >= self._next_frame_t_s

    def capture(self, data: mujoco.MjData) -> None:
        import mujoco.viewer

        start = time.perf_counter()
        if self._handle is None:
            self._handle = mujoco.viewer.launch_passive(self._model, data)
            self._start = (start, float(data.time))
        if not self._handle.is_running():
            raise KeyboardInterrupt  # the window was closed
        wall0, sim0 = self._start
        ahead = (data.time - sim0) - (start - wall0)
        if ahead > 0:
            time.sleep(ahead)
        self._handle.sync()
        self.frame_count += 1
        self._next_frame_t_s += self._period_s
        self.render_time_s += time.perf_counter() - start

    @property
    def frames_per_second(self) -> float:
        return self.frame_count / self.render_time_s if self.render_time_s > 0 else 0.0

    def close(self) -> None:
        if self._handle is not None:
            self._handle.close()
            self._handle = None


class _Both:
    """A video and the viewer at once."""

    def __init__(self, video: VideoRecorder, viewer: ViewerSink) -> None:
        self.video, self.viewer = video, viewer

    def due(self, t_s: float) -> bool:
        return self.video.due(t_s) or self.viewer.due(t_s)

    def capture(self, data: mujoco.MjData) -> None:
        for sink in (self.video, self.viewer):
            if sink.due(data.time):
                sink.capture(data)

    @property
    def frame_count(self) -> int:
        return self.video.frame_count

    @property
    def frames_per_second(self) -> float:
        return self.video.frames_per_second

    def close(self) -> None:
        try:
            self.video.close()
        finally:
            self.viewer.close()


def open_frame_sink(model: mujoco.MjModel, root_body: str, video_path=None, viewer: bool = False, label: str = ""):
    """What the MuJoCo loop hands its frames to: a :class:`VideoRecorder` writing ``video_path``
    (overlay ``label``), the interactive :class:`ViewerSink`, or both."""
    video = VideoRecorder(model, VideoSettings(path=video_path, label=label), root_body) if video_path else None
    if not viewer:
        return video
    check_viewer()
    return ViewerSink(model) if video is None else _Both(video, ViewerSink(model))
