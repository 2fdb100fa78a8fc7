"""Compiled kernels on a path table: interpolation, projection and cone-gate checks, for the env's compiled step
(N cars at once) and for ``Path`` (through ``tracks.interpolation``): one implementation of each.

Arguments are plain arrays/scalars: ``table`` (n, 8) float64 with the column order of ``vtrack_gym.tracks.path``
(COL_X .. COL_ZPP), ``ds`` sample spacing [m], ``length`` = (n - 1) ds [m], ``closed`` (bool; s wraps modulo
length, else it is clamped to [0, length]).

Interpolation: quintic Hermite for X, Y (value, unit tangent, curvature normal), psi (psi, kappa, dkappa) and z
(z, grade, z''); cubic Hermite for kappa (kappa, dkappa) and grade (grade, z''); linear for dkappa and z''. Heading
is interpolated as the unwrapped table angle. Arcs are reproduced to ~1e-15 m, so X/Y at the projection are
consistent with it.
"""

from __future__ import annotations

import math

import numpy as np

from vtrack_gym._jit import kernel

C_X, C_Y, C_PSI, C_KAPPA, C_DKAPPA, C_Z, C_GRADE, C_ZPP = range(8)
N_COLS = C_ZPP + 1    # columns of a table row
TOL_M = 1e-10          # refinement stops when s moves less than this [m]
MAX_ITER = 12
INSIDE_LAP = 1.0 - 1e-12
"""A closed path's station below this fraction of its length is already wrapped (its quotient by the length
rounds below 1 whatever the rounding): ``wrap_s`` returns it without the division."""


@kernel
def wrap_s(s: float, length: float, closed: bool) -> float:
    """Arc length wrapped into [0, length) (closed) or clamped to [0, length] (open) [m]."""
    if closed:
        if 0.0 < s < INSIDE_LAP * length:   # floor(s / length) is 0 there: the formula below gives s itself
            return s
        w = s - math.floor(s / length) * length
        if w >= length or w < 0.0:
            w = 0.0
        return w
    if s < 0.0:
        return 0.0
    if s > length:
        return length
    return s


@kernel
def _h5(p0: float, d0: float, c0: float, p1: float, d1: float, c1: float, t: float, h: float) -> float:
    t2 = t * t
    t3 = t2 * t
    t4 = t3 * t
    t5 = t4 * t
    return ((1.0 - 10.0 * t3 + 15.0 * t4 - 6.0 * t5) * p0 + (t - 6.0 * t3 + 8.0 * t4 - 3.0 * t5) * h * d0
            + 0.5 * (t2 - 3.0 * t3 + 3.0 * t4 - t5) * h * h * c0 + 0.5 * (t3 - 2.0 * t4 + t5) * h * h * c1
            + (-4.0 * t3 + 7.0 * t4 - 3.0 * t5) * h * d1 + (10.0 * t3 - 15.0 * t4 + 6.0 * t5) * p1)


@kernel
def _h3(p0: float, d0: float, p1: float, d1: float, t: float, h: float) -> float:
    t2 = t * t
    t3 = t2 * t
    return ((2.0 * t3 - 3.0 * t2 + 1.0) * p0 + (t3 - 2.0 * t2 + t) * h * d0 + (-2.0 * t3 + 3.0 * t2) * p1
            + (t3 - t2) * h * d1)


@kernel
def _locate(n: int, ds: float, length: float, closed: bool, s: float) -> tuple[int, float]:
    sw = wrap_s(s, length, closed)
    i = int(sw / ds)
    if i > n - 2:
        i = n - 2
    return i, (sw - i * ds) / ds


@kernel(inline=True)
def plane_at(table: np.ndarray, i: int, t: float, ds: float, trig: int) -> tuple[float, float, float, float]:
    """(X [m], Y [m], psi [rad], kappa [1/m]) at fraction t of the interval from row i (the one formula of the
    plane columns, for ``_geom`` and ``interp_row``). ``trig`` >= 0: the table holds cos psi and sin psi of each
    row in columns ``trig`` and ``trig + 1`` (``trig_columns``: the same bits), read instead of computed."""
    a = table[i]
    b = table[i + 1]
    if trig >= 0:
        ca, sa = a[trig], a[trig + 1]
        cb, sb = b[trig], b[trig + 1]
    else:
        ca, sa = math.cos(a[C_PSI]), math.sin(a[C_PSI])
        cb, sb = math.cos(b[C_PSI]), math.sin(b[C_PSI])
    ka, kb = a[C_KAPPA], b[C_KAPPA]
    x = _h5(a[C_X], ca, -ka * sa, b[C_X], cb, -kb * sb, t, ds)
    y = _h5(a[C_Y], sa, ka * ca, b[C_Y], sb, kb * cb, t, ds)
    psi = _h5(a[C_PSI], ka, a[C_DKAPPA], b[C_PSI], kb, b[C_DKAPPA], t, ds)
    kap = _h3(ka, a[C_DKAPPA], kb, b[C_DKAPPA], t, ds)
    return x, y, psi, kap


@kernel(inline=True)
def _geom(table: np.ndarray, ds: float, length: float, closed: bool, s: float,
          trig: int = -1) -> tuple[float, float, float, float]:
    """(X [m], Y [m], psi [rad], kappa [1/m]) at s (``trig``: see ``plane_at``)."""
    i, t = _locate(table.shape[0], ds, length, closed, s)
    return plane_at(table, i, t, ds, trig)


@kernel
def trig_columns(psi: np.ndarray, out: np.ndarray) -> None:
    """cos and sin of each row's heading ``psi`` (M,) [rad] into ``out`` (M, 2): the columns a table passes to
    ``interp_row`` and ``project_point`` as ``trig`` (computed by the same compiled calls as without them, so the
    results keep their bits)."""
    for i in range(psi.shape[0]):
        out[i, 0] = math.cos(psi[i])
        out[i, 1] = math.sin(psi[i])


@kernel(inline=True)
def height_columns(table: np.ndarray, i: int, t: float, ds: float) -> tuple[float, float, float, float]:
    """(dkappa [1/m^2], z [m], grade, z'' [1/m]) at fraction t of the interval from row i: ``interp_row``'s columns
    after the plane's (the one formula of each)."""
    a = table[i]
    b = table[i + 1]
    return (a[C_DKAPPA] + t * (b[C_DKAPPA] - a[C_DKAPPA]),
            _h5(a[C_Z], a[C_GRADE], a[C_ZPP], b[C_Z], b[C_GRADE], b[C_ZPP], t, ds),
            _h3(a[C_GRADE], a[C_ZPP], b[C_GRADE], b[C_ZPP], t, ds),
            a[C_ZPP] + t * (b[C_ZPP] - a[C_ZPP]))


@kernel(inline=True)
def interp_row(table: np.ndarray, ds: float, length: float, closed: bool, s: float, out_row: np.ndarray,
               trig: int = -1) -> None:
    """Write all 8 columns at arc length s [m] into out_row (wrapped for closed, clamped for open paths).
    ``trig`` >= 0: columns ``trig``, ``trig + 1`` of ``table`` hold cos psi, sin psi of each row
    (``trig_columns``)."""
    i, t = _locate(table.shape[0], ds, length, closed, s)
    x, y, psi, kap = plane_at(table, i, t, ds, trig)
    out_row[C_X] = x
    out_row[C_Y] = y
    out_row[C_PSI] = psi
    out_row[C_KAPPA] = kap
    out_row[C_DKAPPA], out_row[C_Z], out_row[C_GRADE], out_row[C_ZPP] = height_columns(table, i, t, ds)


@kernel(inline=True)
def curvature_at(table: np.ndarray, ds: float, length: float, closed: bool, s: float) -> float:
    """Curvature [1/m] at arc length s [m]: ``interp_row``'s kappa column alone (the same formula and bits, without
    the plane's 4 sin/cos and the other 7 columns; what a curvature preview needs)."""
    i, t = _locate(table.shape[0], ds, length, closed, s)
    a = table[i]
    b = table[i + 1]
    return _h3(a[C_KAPPA], a[C_DKAPPA], b[C_KAPPA], b[C_DKAPPA], t, ds)


PREVIEW_BLOCK = 8
"""Stations per pass of ``curvature_preview`` (its scratch holds twice this many floats)."""


@kernel(error_model="numpy", refcount=False)
def curvature_preview(table: np.ndarray, ds: float, length: float, closed: bool, s: float, v: float, dt: float,
                      out: np.ndarray, scratch: np.ndarray) -> None:
    """``out[j] = curvature_at(s + v (j + 1) dt)`` [1/m] for every j: a curvature preview at stations ``s`` [m]
    plus the distance covered at ``v`` [m/s] in (j + 1) times ``dt`` [s] (the same formulas and bits).

    In blocks of ``PREVIEW_BLOCK`` stations: one loop locates them (the interval and the fraction into it; two
    divisions each, which the compiler runs as vectors), a second one reads the rows and interpolates.
    ``scratch``: ``2 PREVIEW_BLOCK`` floats. ``ds`` > 0 (a division by it is not checked)."""
    rows = table.shape[0]
    n = out.shape[0]
    for first in range(0, n, PREVIEW_BLOCK):
        count = min(PREVIEW_BLOCK, n - first)
        for j in range(count):
            sw = wrap_s(s + v * (first + j + 1) * dt, length, closed)
            m = int(sw / ds)
            m = rows - 2 if m > rows - 2 else m
            scratch[j] = m
            scratch[PREVIEW_BLOCK + j] = (sw - m * ds) / ds
        for j in range(count):
            m = int(scratch[j])
            out[first + j] = _h3(table[m, C_KAPPA], table[m, C_DKAPPA], table[m + 1, C_KAPPA],
                                 table[m + 1, C_DKAPPA], scratch[PREVIEW_BLOCK + j], ds)


@kernel(inline=True)
def interp_linear(table: np.ndarray, ds: float, length: float, closed: bool, s: float, col: int) -> float:
    """Column ``col`` of ``table`` at arc length s [m], linear between rows (wrapped / clamped like the path)."""
    j, t = _locate(table.shape[0], ds, length, closed, s)
    return lerp_column(table, j, t, col)


@kernel(inline=True)
def lerp_column(table: np.ndarray, j: int, t: float, col: int) -> float:
    """Column ``col`` at fraction t of the interval from row j, linear (``interp_linear``'s formula)."""
    lo = table[j, col]
    return lo + t * (table[j + 1, col] - lo)


@kernel
def interp_rows(table: np.ndarray, ds: float, length: float, closed: bool, s: np.ndarray, out: np.ndarray) -> None:
    """``interp_row`` at every arc length of ``s`` (M,) [m] into ``out`` (M, 8)."""
    for k in range(s.shape[0]):
        interp_row(table, ds, length, closed, s[k], out[k])


@kernel
def interp_linear_rows(table: np.ndarray, ds: float, length: float, closed: bool, s: np.ndarray,
                       out: np.ndarray) -> None:
    """Every column of ``table`` (n, C) linear between rows at every arc length of ``s`` (M,) [m] into ``out``
    (M, C)."""
    for k in range(s.shape[0]):
        for col in range(table.shape[1]):
            out[k, col] = interp_linear(table, ds, length, closed, s[k], col)


@kernel
def wrap_s_rows(s: np.ndarray, length: float, closed: bool, out: np.ndarray) -> None:
    """``wrap_s`` of every entry of ``s`` (M,) [m] into ``out`` (M,)."""
    for k in range(s.shape[0]):
        out[k] = wrap_s(s[k], length, closed)


@kernel(refcount=False)
def _nearest_sample(table: np.ndarray, ds: float, closed: bool, x: float, y: float, s_guess: float,
                    window_m: float) -> int:
    """Index of the nearest sample within +- window_m of s_guess (all samples if s_guess < 0)."""
    n = table.shape[0]
    period = n - 1
    half = math.ceil(window_m / ds)
    if half < 1:
        half = 1
    best = 0
    best_d2 = np.inf
    if s_guess < 0.0 or (closed and 2 * half + 1 >= period):
        last = period if closed else n
        for j in range(last):
            d2 = (table[j, C_X] - x) ** 2 + (table[j, C_Y] - y) ** 2
            if d2 < best_d2:
                best_d2 = d2
                best = j
        return best
    length = period * ds
    centre = round(wrap_s(s_guess, length, closed) / ds)
    j = centre - half   # the window's samples in order; a closed path's index wraps by one comparison per sample
    if closed:
        j %= period
    for _ in range(2 * half + 1):
        if closed or 0 <= j <= n - 1:
            d2 = (table[j, C_X] - x) ** 2 + (table[j, C_Y] - y) ** 2
            if d2 < best_d2:
                best_d2 = d2
                best = j
        j += 1
        if closed and j == period:
            j = 0
    return best


@kernel(refcount=False)
def project_point(table: np.ndarray, ds: float, length: float, closed: bool, x: float, y: float, s_guess: float,
                  window_m: float, trig: int = -1) -> float:
    """Arc length s* [m] of the closest path point to (x, y) [m].

    Coarse search over the samples within +- window_m [m] of s_guess [m] (warm start; global if s_guess < 0),
    then refinement: project (x, y) exactly onto the osculating circle at the current s and move there, until s
    moves less than 1e-10 m (exact on arcs and straights, a few steps on clothoids). Wrapped for closed paths,
    clamped to [0, length] for open ones. ``trig``: as for ``interp_row`` (the same s, fewer sin / cos).
    """
    s = _nearest_sample(table, ds, closed, x, y, s_guess, window_m) * ds
    step_max = max(4.0 * ds, 2.0)
    for _ in range(MAX_ITER):
        xr, yr, psi, kap = _geom(table, ds, length, closed, s, trig)
        c = math.cos(psi)
        sn = math.sin(psi)
        px = x - xr
        py = y - yr
        along = px * c + py * sn
        lateral = -px * sn + py * c
        if abs(kap) < 1e-12:
            delta = along
        else:
            delta = math.atan2(kap * along, 1.0 - kap * lateral) / kap
        if delta > step_max:
            delta = step_max
        elif delta < -step_max:
            delta = -step_max
        s_new = wrap_s(s + delta, length, closed)
        moved = abs(s_new - s)
        if closed and moved > 0.5 * length:
            moved = length - moved
        s = s_new
        if moved < TOL_M:
            break
    return s


@kernel(inline=True)
def projection_row(table: np.ndarray, ds: float, length: float, closed: bool, x: float, y: float, s_guess: float,
                   window_m: float, trig: int = -1) -> tuple[float, int, float, float, float, float, float, float,
                                                             float]:
    """``project_point``'s s* [m] with the path's plane columns there, as values (no row array): (s*, the
    interval's row and the fraction into it (``height_columns`` and ``lerp_column`` take them), X [m], Y [m], psi
    [rad], kappa [1/m], cos psi, sin psi), the same bits as ``interp_row`` and ``lateral_offset`` at s*."""
    s = project_point(table, ds, length, closed, x, y, s_guess, window_m, trig)
    j, t = _locate(table.shape[0], ds, length, closed, s)
    x_r, y_r, psi_r, kappa = plane_at(table, j, t, ds, trig)
    return s, j, t, x_r, y_r, psi_r, kappa, math.cos(psi_r), math.sin(psi_r)


@kernel
def wrap_angle(a: float) -> float:
    """Angle ``a`` [rad] wrapped to (-pi, pi]: the package's one angle wrap (the env's e_phi, ``tracks.wrap_angle``).

    ``a`` itself (bit for bit) when it is already in (-pi, pi]; else ``a`` minus the nearest multiple of 2 pi, and
    the two ends corrected: the floor of a rounded quotient can leave ``w`` just outside, e.g. ``nextafter(pi, 0)``
    gives ``-pi - ulp`` before the correction (``+ 2 pi`` makes it exact again); ``-pi`` itself becomes ``pi``.
    """
    two_pi = 2.0 * math.pi
    w = a - two_pi * math.floor((a + math.pi) / two_pi)
    if w <= -math.pi:
        w += two_pi
    elif w > math.pi:
        w -= two_pi
    return w


@kernel
def wrap_angle_rows(a: np.ndarray, out: np.ndarray) -> None:
    """``out[i] = wrap_angle(a[i])`` for 1-D float64 arrays [rad]."""
    for i in range(a.shape[0]):
        out[i] = wrap_angle(a[i])


@kernel
def lateral_offset(x: float, y: float, x_ref: float, y_ref: float, psi_ref: float) -> float:
    """Left-positive lateral offset [m] of (x, y) [m] from the line through (x_ref, y_ref) [m] at heading psi_ref
    [rad] (e_y when the reference point is the projection)."""
    return lateral_offset_cs(x, y, x_ref, y_ref, math.cos(psi_ref), math.sin(psi_ref))


@kernel(inline=True)
def lateral_offset_cs(x: float, y: float, x_ref: float, y_ref: float, cos_ref: float, sin_ref: float) -> float:
    """``lateral_offset`` [m] from the reference heading's cosine and sine (the same formula)."""
    return -(x - x_ref) * sin_ref + (y - y_ref) * cos_ref


@kernel
def lateral_error(table: np.ndarray, ds: float, length: float, closed: bool, x: float, y: float,
                  s: float) -> tuple[float, float]:
    """(e_y [m] left-positive, psi_ref [rad]) of (x, y) [m] relative to the path point at s [m]."""
    xr, yr, psi, _ = _geom(table, ds, length, closed, s)
    return lateral_offset(x, y, xr, yr, psi), psi


@kernel
def project_batch(table: np.ndarray, ds: float, length: float, closed: bool, x: np.ndarray, y: np.ndarray,
                  s_guess: np.ndarray, window_m: float, s_out: np.ndarray, e_y_out: np.ndarray,
                  psi_ref_out: np.ndarray) -> None:
    """Project N points (x[i], y[i]) [m]: s* [m], e_y [m] (left-positive) and psi_ref [rad] into the outputs."""
    for i in range(x.shape[0]):
        s = project_point(table, ds, length, closed, x[i], y[i], s_guess[i], window_m)
        e_y, psi = lateral_error(table, ds, length, closed, x[i], y[i], s)
        s_out[i] = s
        e_y_out[i] = e_y
        psi_ref_out[i] = psi


GATE_COLS = 9
"""Columns of a gate row for ``body_outside_gates``: s_start, s_end, y_left, y_right [m], anchored (1.0 / 0.0),
anchor x, y [m], psi [rad], lane length [m] (``tracks.Gate``; the anchor columns are 0 without an anchor)."""


@kernel(inline=True)
def _outside_anchored_gate(gate: np.ndarray, cx: float, cy: float) -> bool:
    """True if point (cx, cy) [m] lies in an anchored gate's lane section (its fixed rectangle) outside its lane."""
    ca = math.cos(gate[7])
    sa = math.sin(gate[7])
    along = (cx - gate[5]) * ca + (cy - gate[6]) * sa
    off = -(cx - gate[5]) * sa + (cy - gate[6]) * ca
    return 0.0 <= along <= gate[8] and (off > gate[2] or off < gate[3])


@kernel
def body_outside_gates(table: np.ndarray, ds: float, length: float, closed: bool, gates: np.ndarray, x: np.ndarray,
                       y: np.ndarray, psi: np.ndarray, s_guess: np.ndarray, lon: np.ndarray, lat: np.ndarray,
                       reach: float, out: np.ndarray, row: np.ndarray) -> None:
    """``out[i, g] = True`` where a body-outline point of car i (CG x, y [m], heading psi [rad]; point offsets
    ``lon``, ``lat`` (P,) [m] in the body frame) lies in gate g's lane section outside its lane. ``gates``
    (G, GATE_COLS): a gate without an anchor is checked in the path's Frenet frame (s range, e_y bounds; the
    projection starts near ``s_guess`` [m], the car's station), an anchored gate against its fixed rectangle.
    A gate already marked in ``out`` is not checked again, nor a Frenet gate whose station range is more than
    ``reach`` [m] (the body length; ``inf`` checks every gate) from the car's station. ``row`` is an 8-float
    scratch row. ``out`` (N, G) is only ever set to True."""
    for i in range(x.shape[0]):
        frenet = False
        anchored = False
        for g in range(gates.shape[0]):
            if out[i, g]:
                continue
            if gates[g, 4] > 0.5:
                anchored = True
            elif gates[g, 0] - reach <= s_guess[i] <= gates[g, 1] + reach:
                frenet = True
        if not (frenet or anchored):
            continue
        c = math.cos(psi[i])
        sn = math.sin(psi[i])
        for j in range(lon.shape[0]):
            cx = x[i] + c * lon[j] - sn * lat[j]
            cy = y[i] + sn * lon[j] + c * lat[j]
            s = 0.0
            e_y = 0.0
            if frenet:
                s = project_point(table, ds, length, closed, cx, cy, s_guess[i], 10.0)
                interp_row(table, ds, length, closed, s, row)
                e_y = lateral_offset(cx, cy, row[C_X], row[C_Y], row[C_PSI])
            for g in range(gates.shape[0]):
                if out[i, g]:
                    continue
                if gates[g, 4] > 0.5:
                    if _outside_anchored_gate(gates[g], cx, cy):
                        out[i, g] = True
                elif frenet and gates[g, 0] <= s <= gates[g, 1] and (e_y > gates[g, 2] or e_y < gates[g, 3]):
                    out[i, g] = True


def gate_rows(gates: tuple) -> np.ndarray:
    """The (G, GATE_COLS) array of ``tracks.Gate`` objects for ``body_outside_gates``."""
    out = np.zeros((len(gates), GATE_COLS))
    for g, gate in enumerate(gates):
        out[g, :4] = (gate.s_start_m, gate.s_end_m, gate.y_left_m, gate.y_right_m)
        if gate.anchor is not None:
            out[g, 4] = 1.0
            out[g, 5:8] = gate.anchor
            out[g, 8] = gate.lane_length_m
    return out
