"""Top-down rendering with matplotlib (imported lazily): track, road edges or cones, the car, the preview."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vtrack_gym.envs.config import EnvConfig
from vtrack_gym.vehicle import layout as L

VIEW_HALF_SIZE_M = 30.0  # half width of the square view around the car [m]


class TopDownRenderer:
    """Draws one car of a ``BatchSim`` on its path; ``human=True`` shows a window instead of returning pixels."""

    def __init__(self, config: EnvConfig, human: bool = False, size_px: int = 480) -> None:
        import matplotlib

        if not human:
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        self._plt = plt
        self.config = config
        self.human = human
        dpi = 80
        self.fig, self.ax = plt.subplots(figsize=(size_px / dpi, size_px / dpi), dpi=dpi)
        if human:
            plt.ion()
            plt.show(block=False)

    def draw(self, path: Any, sim: Any, i: int) -> np.ndarray | None:
        """Render car ``i`` of ``sim`` on ``path``; an (H, W, 3) uint8 image in rgb_array mode."""
        ax = self.ax
        ax.clear()
        st = sim.plant.state[i]
        x, y, psi = st[L.S_X], st[L.S_Y], st[L.S_PSI]
        tab = path.table
        px, py, ppsi = tab[:, 0], tab[:, 1], tab[:, 2]
        near = (np.abs(px - x) < 2 * VIEW_HALF_SIZE_M) & (np.abs(py - y) < 2 * VIEW_HALF_SIZE_M)
        ax.plot(px[near], py[near], "--", color="0.5", lw=1)
        hw = path.half_width_m
        gates = getattr(path, "gates", None)
        if not gates:
            for side in (1.0, -1.0):
                ax.plot(px[near] - side * hw * np.sin(ppsi[near]), py[near] + side * hw * np.cos(ppsi[near]),
                        color="0.2", lw=1.5)
        else:
            self._draw_gates(path)
        c = self.config.vehicle.chassis
        front, rear, half_w = c.cg_to_front_end_m, c.body_length_m - c.cg_to_front_end_m, 0.5 * c.body_width_m
        corners = np.array([[front, half_w], [front, -half_w], [-rear, -half_w], [-rear, half_w], [front, half_w]])
        rot = np.array([[math.cos(psi), -math.sin(psi)], [math.sin(psi), math.cos(psi)]])
        body = corners @ rot.T + [x, y]
        ax.fill(body[:, 0], body[:, 1], color="tab:blue", alpha=0.8)
        lay = sim.layout
        s0 = sim.err[i, 0]
        dists = lay.preview_distances(st[L.S_VX])
        idx = np.clip(((s0 + dists) / path.ds_m).astype(int) % len(px), 0, len(px) - 1)
        ax.plot(px[idx], py[idx], ".", color="tab:orange", ms=4, label="preview")
        ax.set_xlim(x - VIEW_HALF_SIZE_M, x + VIEW_HALF_SIZE_M)
        ax.set_ylim(y - VIEW_HALF_SIZE_M, y + VIEW_HALF_SIZE_M)
        ax.set_aspect("equal")
        ax.set_title(f"t = {sim.steps[i] * self.config.control_period_s:6.2f} s   v = {st[L.S_VX] * 3.6:5.1f} km/h   "
                     f"e_y = {sim.err[i, 1]:+.3f} m", fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
        self.fig.canvas.draw()
        if self.human:
            self._plt.pause(0.001)
            return None
        return np.asarray(self.fig.canvas.buffer_rgba())[..., :3].copy()

    def _draw_gates(self, path: Any) -> None:
        """Cones of the lane-change gates (station range and lateral bounds in path coordinates)."""
        for gate in path.gates:
            for s in np.linspace(gate.s_start_m, gate.s_end_m, 4):
                row = path.sample(float(s))
                gx, gy, gpsi = float(row.x), float(row.y), float(row.psi)
                for lat in (gate.y_left_m, gate.y_right_m):
                    self.ax.plot(gx - lat * math.sin(gpsi), gy + lat * math.cos(gpsi), "^", color="tab:orange", ms=5)

    def close(self) -> None:
        self._plt.close(self.fig)
