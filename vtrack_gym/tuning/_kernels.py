"""Compiled per-step helpers of the population rollout (same arithmetic as ``PopulationSMC`` / the numpy
accumulators; used because one Case-1 generation is ~21 500 steps of a 10-car batch)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from vtrack_gym.baselines.smc import _coefficients, _law

# The SMC's own coefficient and control-law functions (plain arithmetic), compiled: one source for both paths.
_smc_coefficients = njit(cache=True)(_coefficients)
_smc_law = njit(cache=True)(_law)


@njit(cache=True)
def smc_population_actions(obs, idx, k, pole, eta_k, inv_layer, min_speed, v_star, guard, shift, inv_steer,
                           active, actions):
    """Normalised steering actions (P,) of the SMC law (31) with per-row p, eta, Delta; 0 for frozen rows."""
    kt = (k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7])
    iv, iey, iep, ieyd, iepd, ivy, ir, irr, iar = idx[0], idx[1], idx[2], idx[3], idx[4], idx[5], idx[6], idx[7], \
        idx[8]
    for i in range(obs.shape[0]):
        if not active[i]:
            actions[i] = 0.0
            continue
        v = max(float(obs[i, iv]), min_speed)
        if guard > 0.0 and not math.isnan(v_star) and abs(v - v_star) < guard:
            v = v_star - guard if v < v_star else v_star + guard
        e_y, e_phi, e_y_dot, e_phi_dot = float(obs[i, iey]), float(obs[i, iep]), float(obs[i, ieyd]), \
            float(obs[i, iepd])
        v_y, r, rate_ref, acc_ref = float(obs[i, ivy]), float(obs[i, ir]), float(obs[i, irr]), float(obs[i, iar])
        cf = _smc_coefficients(kt, v, pole[i])
        sigma, delta_eq = _smc_law(kt, cf, v, shift, e_y, e_phi, e_y_dot, e_phi_dot, v_y, r, rate_ref, acc_ref)
        z = sigma * inv_layer[i]
        sat = 1.0 if z > 1.0 else (-1.0 if z < -1.0 else z)
        a = (delta_eq - eta_k[i] * sat) * inv_steer
        if not (a == a):  # NaN (a frozen or diverged row): neutral steering
            a = 0.0
        actions[i] = 1.0 if a > 1.0 else (-1.0 if a < -1.0 else a)


@njit(cache=True)
def accumulate(k, dt, err, outputs, o_ay, min_fz_now, term, active, itae, prev_te, max_ay, min_fz, max_steps,
               newly_done):
    """Add step ``k`` to the running ITAE (trapezoid from step 1), max|a_y| and min F_z of the active cars and
    flag those that terminated (or hit ``max_steps``) in ``newly_done``; returns how many did."""
    count = 0
    t = k * dt
    for i in range(err.shape[0]):
        te = t * abs(err[i, 1])
        newly_done[i] = False
        if active[i]:
            if k >= 2:
                itae[i] += 0.5 * dt * (prev_te[i] + te)
            for j in range(outputs.shape[1]):
                ay = abs(outputs[i, j, o_ay])
                if ay > max_ay[i]:
                    max_ay[i] = ay
            if min_fz_now[i] < min_fz[i]:
                min_fz[i] = min_fz_now[i]
            if term[i] != 0 or k >= max_steps:
                newly_done[i] = True
                count += 1
        prev_te[i] = te
    return count


def as_index(values) -> np.ndarray:
    return np.asarray(values, dtype=np.int64)


@njit(cache=True)
def mpc_population_actions(obs, idx, pv0, pv1, pv_vmin, pv_dt, preview, n_out, ts, n_hold, max_du, max_steer,
                           speeds, tables, slopes, inv_steer, state, active, z, actions):
    """``PopulationMPC._act_batch`` row by row (per-row gain tables (P, S, width)); updates ``state`` (P, 9) in
    place and writes the normalised actions (0 for frozen rows)."""
    iv, ivy, ir, iey, ieyd, iep, iepd, iacc, ik, ikr = idx[0], idx[1], idx[2], idx[3], idx[4], idx[5], idx[6], \
        idx[7], idx[9], idx[10]
    half = 0.5 * ts
    two_pi = 2.0 * math.pi
    s_last = speeds.shape[0] - 2
    width = tables.shape[2]
    for p in range(obs.shape[0]):
        if not active[p]:
            actions[p] = 0.0
            continue
        st = state[p]
        if st[8] >= 0.5:
            st[8] -= 1.0
        else:
            vy, r, ey, eyd, ep, epd = float(obs[p, ivy]), float(obs[p, ir]), float(obs[p, iey]), \
                float(obs[p, ieyd]), float(obs[p, iep]), float(obs[p, iepd])
            v_x = float(obs[p, iv])
            if preview:
                v = max(v_x, 0.0)
                x1 = max(v, pv_vmin) * pv_dt
                d0 = float(obs[p, iacc]) + v * v * ((float(obs[p, pv0]) - float(obs[p, ik])) / x1
                                                    - float(obs[p, ikr]))
            else:
                d0 = float(obs[p, iacc])
            z[0] = half * (vy + st[0])
            z[1] = vy - st[0]
            z[2] = half * (r + st[1])
            z[3] = r - st[1]
            z[4] = ey - st[2]
            z[5] = eyd - st[3]
            z[6] = (ep - st[4] + math.pi) % two_pi - math.pi
            z[7] = epd - st[5]
            z[8] = ey
            j = 9
            if n_out == 2:
                z[9] = ep
                j = 10
            z[j] = d0 - st[7]
            z[j + 1] = float(obs[p, ik])
            for q in range(pv1 - pv0):
                z[j + 2 + q] = float(obs[p, pv0 + q])
            z[width - 1] = float(obs[p, ikr])
            vc = min(max(v_x, speeds[0]), speeds[s_last + 1])
            i = np.searchsorted(speeds, vc, side="right") - 1
            i = 0 if i < 0 else (s_last if i > s_last else i)
            t = (vc - speeds[i]) / (speeds[i + 1] - speeds[i])
            acc = 0.0
            for c in range(width):
                acc += (tables[p, i, c] + t * slopes[p, i, c]) * z[c]
            du = -acc
            du = max_du if du > max_du else (-max_du if du < -max_du else du)
            u = st[6] + du
            u = max_steer if u > max_steer else (-max_steer if u < -max_steer else u)
            st[0], st[1], st[2], st[3], st[4], st[5] = vy, r, ey, eyd, ep, epd
            st[6] = u
            st[7] = d0
            st[8] = n_hold - 1.0
        a = st[6] * inv_steer
        actions[p] = 1.0 if a > 1.0 else (-1.0 if a < -1.0 else a)
