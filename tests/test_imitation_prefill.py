"""The SAC warm start's replay prefill marks time-limit ends as SB3 does (a timeout, bootstrapped), not as true
terminals (they were stored with empty infos, so every time-limit end taught the critic a zero future)."""

from __future__ import annotations

import numpy as np

from vtrack_gym.agents.imitation import ExpertData, prefill_replay_buffer
from vtrack_gym.envs.observation import OBS


def test_time_limit_ends_are_stored_as_timeouts_and_terminals_as_terminals() -> None:
    import gymnasium as gym
    from stable_baselines3 import SAC

    model = SAC("MlpPolicy", gym.make("DLC120-v0"), buffer_size=64, learning_starts=0, seed=0)
    steps, n = 4, 1
    shape = (steps, n)
    done = np.zeros(shape, bool)
    done[1, 0] = done[3, 0] = True               # step 1: the time limit; step 3: off the road
    truncated = np.zeros(shape, bool)
    truncated[1, 0] = True
    obs = np.zeros((*shape, OBS.size), np.float32)
    data = ExpertData(obs, np.zeros(shape, np.float32), np.zeros(shape, np.float32), np.ones(shape, np.float32),
                      done, obs.copy(), {"time_limit": 1, "off_road": 1}, truncated)
    assert prefill_replay_buffer(model, [data]) == 4
    buf = model.replay_buffer
    assert buf.dones[:4, 0].tolist() == [0.0, 1.0, 0.0, 1.0]
    assert buf.timeouts[:4, 0].tolist() == [0.0, 1.0, 0.0, 0.0]
