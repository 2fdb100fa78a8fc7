"""How long each baseline takes to settle from highway-env's 4 m start offset on ``lane-keeping-v0``.

Drives ``HighwayLaneKeeping`` (highway-env's own sine lane and start, seed 0) with every baseline, with both
the GA-tuned default and the ``hand`` preset of ``smc`` and ``mpc``, and with the shipped RL agents, and prints
the settling time (the last time |e_y| exceeds 0.15 m, the bound of ``tests/test_highway_interop.py``), the
max |e_y| after 15 s and the termination. Needs the ``highway`` extra.
Run: ``python benchmarks/highway_settling.py``.
"""

from __future__ import annotations

import numpy as np

SETTLED_M = 0.15


def main() -> None:
    from vtrack_gym.baselines.registry import available_policies, make_policy
    from vtrack_gym.baselines.shipped import shipped_agent_factories
    from vtrack_gym.evaluation.rollouts.rollout import rollout
    from vtrack_gym.interop.highway import HighwayLaneKeeping

    agents = shipped_agent_factories()
    runs = [(name, "default") for name in available_policies() if name != "mpc_osqp"]
    runs += [("smc", "hand"), ("mpc", "hand"), *((name, "shipped agent") for name in sorted(agents))]
    print("| policy | preset | settling time [s] | max abs e_y after 15 s [m] | termination |")
    print("|---|---|---|---|---|")
    for name, preset in runs:
        env = HighwayLaneKeeping()
        policy = agents[name](env) if preset == "shipped agent" else make_policy(name, env, preset=preset)
        trace = rollout(policy, env, seed=0)
        env.close()
        t, e_y = trace["time_s"], np.abs(trace["e_y_m"])
        outside = np.flatnonzero(e_y > SETTLED_M)
        settle = float(t[outside[-1]]) if outside.size else 0.0
        late = float(e_y[t >= 15.0].max()) if np.any(t >= 15.0) else float("nan")
        print(f"| {name} | {preset} | {settle:.1f} | {late:.3f} | {trace.termination} |")


if __name__ == "__main__":
    main()
