"""Top-down frames of one or more cars on a track, drawn with Pillow (imported lazily).

The static part (grass, road, edges, reference line, cones) is drawn once: into one background image for the
whole-track view, or into 512-px tiles cached on demand for the follow camera. A frame copies the background
window, then draws the preview points, the car(s) with steered front wheels, a scale bar and a readout
(time, speed, lateral error, hand-wheel angle). A 640x384 follow frame takes about 1-2 ms.

``FrameClock`` takes frames at ``fps`` of simulated time (not every 100 Hz control step); ``HumanWindow``
shows frames in a Tk window at real time and raises ``RenderUnavailable`` naming what is missing
(a display, tkinter) when it cannot.
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from vtrack_gym.envs.palette import hex_to_rgb
from vtrack_gym.tracks.table import COL_PSI, COL_X, COL_Y
from vtrack_gym.vehicle import layout as L

VIEWS: tuple[str, ...] = ("follow", "track")
TILE_PX = 512
MAX_TILES = 96  # tile cache bound (~75 MB at 512 px)

GRASS = (96, 140, 80)
ROAD = (88, 88, 92)
EDGE = (235, 235, 235)
REFERENCE = (200, 200, 200)
CONE = (255, 215, 0)
PREVIEW = (255, 255, 255)
TEXT = (255, 255, 255)
PANEL = (0, 0, 0)


class RenderUnavailable(RuntimeError):
    """``render_mode='human'`` cannot open a window here (the message names what is missing)."""


@dataclass(frozen=True)
class RenderConfig:
    """How frames look: ``width_px`` x ``height_px`` pixels, ``view`` 'follow' (camera centred on the first car,
    ``view_width_m`` metres across) or 'track' (the whole track), ``fps`` frames per second of simulated time."""

    width_px: int = 640
    height_px: int = 384
    view: str = "follow"
    view_width_m: float = 60.0
    fps: int = 25
    show_preview: bool = True
    show_readout: bool = True

    def __post_init__(self) -> None:
        for name in ("width_px", "height_px"):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or not 64 <= v <= 4096 or v % 2:
                raise ValueError(f"RenderConfig.{name} must be an even integer in [64, 4096] (got {v!r})")
        if self.view not in VIEWS:
            raise ValueError(f"RenderConfig.view must be one of {VIEWS} (got {self.view!r})")
        if not (isinstance(self.view_width_m, int | float) and 5.0 <= self.view_width_m <= 2000.0):
            raise ValueError(f"RenderConfig.view_width_m must be in [5, 2000] m (got {self.view_width_m!r})")
        if not isinstance(self.fps, int) or isinstance(self.fps, bool) or not 1 <= self.fps <= 120:
            raise ValueError(f"render_fps must be an integer in [1, 120] frames/s (got {self.fps!r})")


class CarView(NamedTuple):
    """What a frame shows of one car (SI units, world frame)."""

    x_m: float
    y_m: float
    psi_rad: float
    road_wheel_angle_rad: float
    v_mps: float
    e_y_m: float
    hand_wheel_deg: float
    label: str = ""
    colour: str = "#1f77b4"
    preview_xy: np.ndarray | None = None  # (n, 2) preview points [m]
    status: str = ""
    trail_xy: np.ndarray | None = None  # (n, 2) recent positions [m], drawn as a line


def car_view(sim: Any, path: Any, i: int, label: str = "", colour: str = "#1f77b4", status: str = "") -> CarView:
    """The ``CarView`` of car ``i`` of a ``BatchSim`` on ``path`` (preview points from the observation layout)."""
    st = sim.plant.state[i]
    v = float(st[L.S_VX])
    delta = float(st[L.S_DELTA])
    s0 = float(sim.station_m[i])
    ratio = float(sim.config.vehicle.steering.steering_ratio)
    return CarView(float(st[L.S_X]), float(st[L.S_Y]), float(st[L.S_PSI]), delta, v, float(sim.lateral_error_m[i]),
                   math.degrees(delta * ratio), label, colour,
                   preview_points(path, s0 + sim.layout.preview_distances(v)), status)


def preview_points(path: Any, s: np.ndarray) -> np.ndarray:
    """(n, 2) centre-line points [m] at stations ``s`` (linear between the path's table rows: for drawing)."""
    tab = path.table
    grid = np.arange(len(tab)) * float(path.ds_m)
    period = float(path.length_m) if path.closed else None
    return np.column_stack([np.interp(s, grid, tab[:, COL_X], period=period),
                            np.interp(s, grid, tab[:, COL_Y], period=period)])


def nice_length(target_m: float) -> float:
    """The largest 1, 2 or 5 x 10^k metres not above ``target_m`` (the scale bar's length)."""
    k = math.floor(math.log10(max(target_m, 1e-6)))
    for m in (5.0, 2.0, 1.0):
        if m * 10.0**k <= target_m:
            return m * 10.0**k
    return 10.0**k


class FrameClock:
    """Frames at ``fps`` of simulated time: ``due(t)`` is True once per frame instant k/fps that ``t`` reached."""

    def __init__(self, fps: int) -> None:
        self.fps = fps
        self._last = -1

    def reset(self) -> None:
        self._last = -1

    def due(self, time_s: float) -> bool:
        k = math.floor(time_s * self.fps + 1e-6)
        if k > self._last:
            self._last = k
            return True
        return False


def _font(size: int) -> Any:
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except (TypeError, OSError):  # Pillow without FreeType: the fixed bitmap font
        return ImageFont.load_default()


class TopDownRenderer:
    """Frames of cars on one ``path``; ``chassis`` gives the car's size (``ChassisParams``)."""

    def __init__(self, path: Any, chassis: Any, config: RenderConfig | None = None) -> None:
        from PIL import Image, ImageDraw

        self._Image, self._ImageDraw = Image, ImageDraw
        self.path = path
        self.config = config or RenderConfig()
        cfg = self.config
        self._text = GlyphText(_font(max(10, cfg.height_px // 30)))
        self._car = (float(chassis.cg_to_front_end_m), float(chassis.body_length_m - chassis.cg_to_front_end_m),
                     0.5 * float(chassis.body_width_m), float(chassis.cg_to_front_axle_m),
                     float(chassis.cg_to_rear_axle_m), 0.5 * float(chassis.track_width_m))
        tab = path.table
        hw = float(path.half_width_m)
        x0, x1 = float(tab[:, COL_X].min()), float(tab[:, COL_X].max())
        y0, y1 = float(tab[:, COL_Y].min()), float(tab[:, COL_Y].max())
        margin = hw + 3.0
        if cfg.view == "track":
            span_x, span_y = x1 - x0 + 2 * margin, y1 - y0 + 2 * margin
            self.px_per_m = min(cfg.width_px / span_x, cfg.height_px / span_y)
            cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
            self._origin = (cx - 0.5 * cfg.width_px / self.px_per_m, cy + 0.5 * cfg.height_px / self.px_per_m)
        else:
            self.px_per_m = cfg.width_px / cfg.view_width_m
            self._origin = (x0 - margin, y1 + margin)
        self._static_px = self._static_geometry()
        self._tiles: dict[tuple[int, int], Any] = {}
        self._background = self._draw_static_region(0, 0, cfg.width_px, cfg.height_px) if cfg.view == "track" \
            else None

    # ------------------------------------------------------------------ static layer
    def to_px(self, x: np.ndarray | float, y: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """World [m] -> global pixel coordinates (y down)."""
        return ((np.asarray(x) - self._origin[0]) * self.px_per_m, (self._origin[1] - np.asarray(y)) * self.px_per_m)

    def _static_geometry(self) -> dict[str, Any]:
        path, tab = self.path, self.path.table
        hw = float(path.half_width_m)
        x, y, psi = tab[:, COL_X], tab[:, COL_Y], tab[:, COL_PSI]
        if path.closed:
            x, y, psi = np.append(x, x[0]), np.append(y, y[0]), np.append(psi, psi[0])
        nx, ny = -np.sin(psi), np.cos(psi)
        s = np.arange(len(x)) * float(path.ds_m)
        geo = {"centre": np.column_stack(self.to_px(x, y)),
               "left": np.column_stack(self.to_px(x + hw * nx, y + hw * ny)),
               "right": np.column_stack(self.to_px(x - hw * nx, y - hw * ny)),
               "dash": (np.floor(s / 3.0) % 2 == 0), "cones": np.zeros((0, 2))}
        cones = []
        from vtrack_gym.tracks import gate_boundaries  # cones at their true positions (anchored gates too)

        for gate in getattr(path, "gates", ()) or ():
            n = max(2, round(gate.lane_length_m / 5.0) + 1)
            for line in gate_boundaries(path, gate, n):
                cones.append(np.column_stack(self.to_px(line[:, 0], line[:, 1])))
        if cones:
            geo["cones"] = np.vstack(cones)
        return geo

    def _draw_static_region(self, left: int, top: int, width: int, height: int) -> Any:
        """The static layer of global pixel rectangle (left, top, width, height) as a Pillow RGB image."""
        img = self._Image.new("RGB", (width, height), GRASS)
        draw = self._ImageDraw.Draw(img)
        geo = self._static_px
        off = np.array([left, top], dtype=np.float64)
        road_px = max(1, round(2.0 * float(self.path.half_width_m) * self.px_per_m))
        pad = road_px + 4
        inside = ((geo["centre"][:, 0] > left - pad) & (geo["centre"][:, 0] < left + width + pad)
                  & (geo["centre"][:, 1] > top - pad) & (geo["centre"][:, 1] < top + height + pad))
        for run in _runs(inside):
            lo, hi = max(run[0] - 1, 0), min(run[1] + 1, len(inside))
            pts = geo["centre"][lo:hi] - off
            outline = np.vstack([geo["left"][lo:hi], geo["right"][lo:hi][::-1]]) - off
            draw.polygon([tuple(p) for p in outline], fill=ROAD)
            for side in ("left", "right"):
                draw.line([tuple(p) for p in geo[side][lo:hi] - off], fill=EDGE, width=max(1, round(0.15 *
                                                                                                     self.px_per_m)))
            for dash in _runs(geo["dash"][lo:hi]):
                seg = pts[dash[0]:dash[1] + 1]
                if len(seg) > 1:
                    draw.line([tuple(p) for p in seg], fill=REFERENCE, width=max(1, round(0.12 * self.px_per_m)))
        r = max(1.5, 0.3 * self.px_per_m)
        for cx, cy in geo["cones"] - off:
            if -r < cx < width + r and -r < cy < height + r:
                draw.ellipse((cx - r, cy - r, cx + r, cy + r), fill=CONE, outline=(0, 0, 0))
        return img

    def _tile(self, tx: int, ty: int) -> Any:
        key = (tx, ty)
        tile = self._tiles.get(key)
        if tile is None:
            if len(self._tiles) >= MAX_TILES:
                self._tiles.pop(next(iter(self._tiles)))
            tile = self._draw_static_region(tx * TILE_PX, ty * TILE_PX, TILE_PX, TILE_PX)
            self._tiles[key] = tile
        return tile

    def _window(self, left: int, top: int) -> Any:
        """Static layer of the frame whose top-left corner is global pixel (left, top), pasted from tiles."""
        w, h = self.config.width_px, self.config.height_px
        out = self._Image.new("RGB", (w, h))
        for ty in range(math.floor(top / TILE_PX), math.floor((top + h - 1) / TILE_PX) + 1):
            for tx in range(math.floor(left / TILE_PX), math.floor((left + w - 1) / TILE_PX) + 1):
                out.paste(self._tile(tx, ty), (tx * TILE_PX - left, ty * TILE_PX - top))  # Pillow clips
        return out

    # ------------------------------------------------------------------ dynamic layer
    def frame(self, cars: Sequence[CarView], time_s: float, title: str = "") -> np.ndarray:
        """An (H, W, 3) uint8 frame of ``cars`` at ``time_s``; the follow camera centres on ``cars[0]``."""
        cfg = self.config
        if cfg.view == "track":
            left, top = 0, 0
            img = self._background.copy()
        else:
            gx, gy = self.to_px(cars[0].x_m, cars[0].y_m) if cars else (0.0, 0.0)
            left, top = round(float(gx)) - cfg.width_px // 2, round(float(gy)) - cfg.height_px // 2
            img = self._window(left, top)
        draw = self._ImageDraw.Draw(img)
        off = np.array([left, top], dtype=np.float64)
        for car in cars:
            if cfg.show_preview and car.preview_xy is not None and len(car.preview_xy):
                px = np.column_stack(self.to_px(car.preview_xy[:, 0], car.preview_xy[:, 1])) - off
                r = max(1.5, 0.25 * self.px_per_m)
                for cx, cy in px:
                    draw.ellipse((cx - r, cy - r, cx + r, cy + r), outline=PREVIEW)
        for car in cars:
            if car.trail_xy is not None and len(car.trail_xy) > 1:
                px = np.column_stack(self.to_px(car.trail_xy[:, 0], car.trail_xy[:, 1])) - off
                draw.line([tuple(p) for p in px], fill=hex_to_rgb(car.colour), width=2)
        for k in range(len(cars) - 1, -1, -1):  # the first car on top, the others as outlines
            self._draw_car(draw, cars[k], off, filled=k == 0)
        bar_text = self._draw_scale_bar(draw)
        self._text.draw(img, *bar_text, TEXT)
        if cfg.show_readout:
            self._draw_readout(img, draw, cars, time_s, title)
        return np.asarray(img, dtype=np.uint8)

    def _draw_car(self, draw: Any, car: CarView, off: np.ndarray, filled: bool = True) -> None:
        front, rear, half_w, lf, lr, half_t = self._car
        c, s = math.cos(car.psi_rad), math.sin(car.psi_rad)

        def poly(points: np.ndarray) -> list[tuple[float, float]]:
            wx = car.x_m + points[:, 0] * c - points[:, 1] * s
            wy = car.y_m + points[:, 0] * s + points[:, 1] * c
            gx, gy = self.to_px(wx, wy)
            return list(zip((gx - off[0]).tolist(), (gy - off[1]).tolist(), strict=True))

        body = np.array([[front, half_w], [front, -half_w], [-rear, -half_w], [-rear, half_w]])
        rgb = hex_to_rgb(car.colour)
        if not filled:
            draw.polygon(poly(body), outline=rgb, width=2)
            return
        inner = body * [[0.92, 0.8]]
        draw.polygon(poly(body), fill=(0, 0, 0))
        draw.polygon(poly(inner), fill=rgb)
        windscreen = np.array([[0.45 * front, 0.7 * half_w], [0.45 * front, -0.7 * half_w],
                               [0.1 * front, -0.7 * half_w], [0.1 * front, 0.7 * half_w]])
        draw.polygon(poly(windscreen), fill=(30, 40, 60))
        wheel_l, wheel_w = 0.33, 0.11  # half length / half width of a tyre [m], drawn over the body
        for ax, steer in ((lf, car.road_wheel_angle_rad), (-lr, 0.0)):
            cs, sn = math.cos(steer), math.sin(steer)
            for side in (half_t, -half_t):
                tyre = np.array([[wheel_l, wheel_w], [wheel_l, -wheel_w], [-wheel_l, -wheel_w], [-wheel_l, wheel_w]])
                tyre = tyre @ np.array([[cs, sn], [-sn, cs]]) + [ax, side]
                draw.polygon(poly(tyre), fill=(20, 20, 20))

    def _draw_scale_bar(self, draw: Any) -> tuple[int, int, str]:
        """Draws the bar; returns (x, y, text) of its label."""
        cfg = self.config
        length_m = nice_length(0.2 * cfg.width_px / self.px_per_m)
        n = max(1, round(length_m * self.px_per_m))
        x0, y0 = 12, cfg.height_px - 14
        draw.rectangle((x0 - 4, y0 - 20, x0 + n + 50, y0 + 8), fill=PANEL)
        draw.line([(x0, y0), (x0 + n, y0)], fill=TEXT, width=3)
        for xe in (x0, x0 + n):
            draw.line([(xe, y0 - 5), (xe, y0 + 5)], fill=TEXT, width=2)
        return x0 + n + 6, y0 - self._text.height // 2, f"{length_m:g} m"

    def _draw_readout(self, img: Any, draw: Any, cars: Sequence[CarView], time_s: float, title: str) -> None:
        lines = [f"{title}  t = {time_s:6.2f} s".strip()]
        colours = [TEXT]
        for car in cars:
            name = f"{car.label:<10.10s} " if car.label else ""
            lines.append(f"{name}v {car.v_mps * 3.6:5.1f} km/h  e_y {car.e_y_m:+6.3f} m  "
                         f"wheel {car.hand_wheel_deg:+6.1f} deg {car.status}".rstrip())
            colours.append(hex_to_rgb(car.colour) if len(cars) > 1 else TEXT)
        line_h = self._text.height + 2
        masks = [self._text.mask(t) for t in lines]
        width = max(m.shape[1] for m in masks)
        draw.rectangle((4, 4, 12 + width, 8 + line_h * len(lines)), fill=PANEL)
        for k, (m, col) in enumerate(zip(masks, colours, strict=True)):
            self._text.draw(img, 8, 6 + k * line_h, m, col)


class GlyphText:
    """Text pasted from cached glyph masks (one FreeType call per new character, not per frame)."""

    def __init__(self, font: Any) -> None:
        from PIL import Image, ImageDraw

        self._font = font
        self._Image, self._ImageDraw = Image, ImageDraw
        ascent, descent = font.getmetrics() if hasattr(font, "getmetrics") else (11, 2)
        self.height = int(ascent + descent)
        self._glyphs: dict[str, np.ndarray] = {}

    def _glyph(self, ch: str) -> np.ndarray:
        g = self._glyphs.get(ch)
        if g is None:
            w = max(1, math.ceil(self._font.getlength(ch)))
            img = self._Image.new("L", (w, self.height), 0)
            self._ImageDraw.Draw(img).text((0, 0), ch, fill=255, font=self._font)
            g = self._glyphs[ch] = np.asarray(img, dtype=np.uint8)
        return g

    def mask(self, text: str) -> np.ndarray:
        """(height, width) uint8 coverage of ``text``."""
        if not text:
            return np.zeros((self.height, 0), dtype=np.uint8)
        return np.ascontiguousarray(np.concatenate([self._glyph(c) for c in text], axis=1))

    def draw(self, img: Any, x: int, y: int, text: str | np.ndarray, colour: tuple[int, int, int]) -> None:
        """Paint ``text`` (or its ``mask``) in ``colour`` onto the Pillow image ``img``, top-left corner at (x, y)."""
        mask = self.mask(text) if isinstance(text, str) else text
        h, w = mask.shape
        if w:
            img.paste(colour, (x, y, x + w, y + h), self._Image.fromarray(mask))


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) index pairs of the True runs of a boolean array."""
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    d = np.flatnonzero(np.diff(m.astype(np.int8)))
    return list(zip(d[0::2].tolist(), d[1::2].tolist(), strict=True))


def display_problem() -> str | None:
    """Why no window can open here (``None`` when a display and tkinter are available)."""
    if sys.platform.startswith("linux") or sys.platform.startswith("freebsd"):
        if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
            return ("no display: $DISPLAY and $WAYLAND_DISPLAY are unset (headless machine or SSH without -X); use "
                    "render_mode='rgb_array' or `vtrack video`, or run under xvfb-run")
    try:
        import tkinter  # noqa: F401

        from PIL import ImageTk  # noqa: F401
    except ImportError as exc:
        return (f"render_mode='human' needs tkinter and Pillow's ImageTk ({exc}); on Debian/Ubuntu: "
                "apt install python3-tk")
    return None


class HumanWindow:
    """A Tk window showing frames at real time (``fps`` frames per second of simulated time)."""

    def __init__(self, title: str, fps: int) -> None:
        problem = display_problem()
        if problem is not None:
            raise RenderUnavailable(f"render_mode='human' cannot open a window: {problem}")
        import tkinter

        try:
            self._root = tkinter.Tk()
        except tkinter.TclError as exc:
            raise RenderUnavailable(f"render_mode='human' cannot open a window: Tk failed ({exc}); "
                                    "use render_mode='rgb_array' or `vtrack video`") from None
        self._root.title(title)
        self._label = tkinter.Label(self._root)
        self._label.pack()
        self._fps = fps
        self._next_wall = 0.0
        self.closed = False

    def show(self, frame: np.ndarray) -> None:
        """Display ``frame`` and wait until its real-time instant (returns at once once the user closed it)."""
        if self.closed:
            return
        import tkinter

        from PIL import Image, ImageTk

        try:
            photo = ImageTk.PhotoImage(Image.fromarray(frame))
            self._label.configure(image=photo)
            self._label.image = photo  # keep a reference: Tk does not
            self._root.update()
        except tkinter.TclError:  # window closed by the user
            self.closed = True
            return
        now = time.perf_counter()
        if self._next_wall > now:
            time.sleep(self._next_wall - now)
        self._next_wall = max(now, self._next_wall) + 1.0 / self._fps

    def close(self) -> None:
        if not self.closed:
            import tkinter

            try:
                self._root.destroy()
            except tkinter.TclError:
                pass
            self.closed = True


class EnvRenderer:
    """Rendering state of one env: the render mode, a renderer per track, the frame clock, the human window.

    - ``rgb_array``: ``render()`` draws the current state (one frame per call);
    - ``rgb_array_list``: frames are taken at ``fps`` of simulated time during ``reset``/``step``;
      ``render()`` returns the frames since the previous call (what ``RecordVideo`` needs for real-time video);
    - ``human``: the same frames shown in a window at real time.

    ``gymnasium.wrappers.RecordVideo`` asks for one frame per env step and plays them at ``render_fps``: with
    ``rgb_array_list`` that is a real-time video at ``render_fps`` (Gymnasium warns once that the steps between
    frames have none); with ``rgb_array`` it holds every 10 ms step, so pass ``fps=100`` for real time.
    """

    def __init__(self, mode: str, config: RenderConfig, chassis: Any, control_period_s: float, title: str) -> None:
        self.mode = mode
        self.config = config
        self._chassis = chassis
        self._dt = control_period_s
        self._title = title
        self._renderers: dict[int, TopDownRenderer] = {}
        self._clock = FrameClock(config.fps)
        self._frames: list[np.ndarray] = []
        self._window: HumanWindow | None = None
        if mode == "human":
            problem = display_problem()
            if problem is not None:
                raise RenderUnavailable(f"render_mode='human' cannot open a window: {problem}")

    def draw(self, path: Any, sim: Any, i: int = 0) -> np.ndarray:
        """A frame of car ``i`` of ``sim`` now."""
        renderer = self._renderers.get(id(path))
        if renderer is None:
            if len(self._renderers) >= 4:
                self._renderers.clear()
            renderer = self._renderers[id(path)] = TopDownRenderer(path, self._chassis, self.config)
        return renderer.frame([car_view(sim, path, i)], float(sim.steps[i]) * self._dt, self._title)

    def on_reset(self, path: Any, sim: Any, i: int = 0) -> None:
        self._clock.reset()
        self._frames.clear()
        self.on_step(path, sim, i)

    def on_step(self, path: Any, sim: Any, i: int = 0) -> None:
        """Take a frame if a frame instant was reached (modes rgb_array_list and human)."""
        if self.mode == "rgb_array" or not self._clock.due(float(sim.steps[i]) * self._dt):
            return
        frame = self.draw(path, sim, i)
        if self.mode == "rgb_array_list":
            self._frames.append(frame)
        else:
            self._show(frame)

    def _show(self, frame: np.ndarray) -> None:
        if self._window is None:
            self._window = HumanWindow(self._title, self.config.fps)
        self._window.show(frame)

    def render(self, path: Any, sim: Any, i: int = 0) -> np.ndarray | list[np.ndarray] | None:
        if self.mode == "rgb_array":
            return self.draw(path, sim, i)
        if self.mode == "rgb_array_list":
            frames, self._frames = self._frames, []
            return frames
        self._show(self.draw(path, sim, i))
        return None

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
            self._window = None
        self._renderers.clear()
