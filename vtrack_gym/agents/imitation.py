"""Behaviour-cloning warm start of an SB3 PPO/SAC agent from a scripted expert (``vtrack train --bc-expert lqr``).

RL from scratch on this task is slow: at 120 km/h a steering error of 5 % of the range is a lane change, and
random exploration mostly teaches spinning out. The warm start gives the agent the expert's behaviour first,
then RL improves it on the env's reward:

1. ``collect``: the expert (any registry baseline and preset; default LQR, stateless, so a feed-forward network
   can represent it exactly in principle) drives the training env (``LateralTrackingRandom-v0``: procedural
   tracks, never the evaluation courses) on the native vector env. The executed action is the expert's plus a
   temporally correlated perturbation (AR(1), ``noise_std`` at <= 10 m/s, falling as 1/v^2 above: a constant
   lateral-acceleration perturbation), so the data also cover the states just off the expert's path and how the
   expert recovers from them (noise injection, as in DART); the label is always the expert's own action.
   In the longitudinal control modes (``control="steer_accel"`` / ``"steer_rate_accel"``) the expert is the
   steering law paired with the paper's PD-FLC (``make_policy``'s decoupled design), the labels and the actor
   have two entries ``[steering, demand]`` and the demand gets its own perturbation (``demand_noise_std``).
   ``dagger_rounds`` further rounds are driven by the cloned agent itself and labelled by the expert (DAgger),
   so the data also hold the states the clone's own errors lead to; the fit runs on the aggregate.
2. ``warm_start``: running observation statistics are set from the data (fixed physical scales,
   the recipes' callback, are kept as they are: ``obs_scaling.FrozenStatistics``); the actor's mean is regressed on the
   expert's actions (MSE, normalised observations); PPO's value function is regressed on the discounted returns
   of the last round's data (VecNormalize's return statistics set from the same data); the exploration std is
   set to ``exp(init_log_std)``. For SAC the data go into its replay buffer (``prefill_replay_buffer``) and the
   critics are trained alone on them first (``pretrain_critic``), so that the first actor updates follow a
   critic that knows the cloned policy instead of a random one. With ``bc_weight`` in the YAML's ``bc_finetune``
   (the default for SAC) the fine-tuning is ``regularised_sac.RegularisedSAC``, whose actor loss keeps a
   regression on the expert labels of all rounds (TD3+BC style); plain SAC forgets the clone within a few
   hundred gradient steps.

Everything here runs only when training is asked for (torch and SB3 are imported lazily).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate

NOISE_REFERENCE_SPEED_MPS = 10.0
"""Above this speed the perturbation std falls as 1/v^2 (a constant lateral-acceleration perturbation)."""


@documented
@dataclass(frozen=True)
class BCConfig:
    """Settings of the warm start (durations [s], actions as fractions of the steering range)."""

    expert: str = "lqr"            # registry name of the scripted expert
    expert_preset: str = "default"
    # vector-env steps of data collection per round (x n_envs transitions)
    steps: int = ranged(3000, ge=10, le=10**6, integer=True)
    # further rounds driven by the cloned agent, labelled by the expert (DAgger)
    dagger_rounds: int = ranged(2, ge=0, le=20, integer=True)
    noise_std: float = ranged(0.02, ge=0.0, le=1.0)  # std of the AR(1) perturbation of the executed action at <= 10 m/s
    noise_corr_s: float = ranged(0.2, ge=0.0, le=10.0, unit="s")  # correlation time of the perturbation [s]
    # longitudinal modes: std of the AR(1) perturbation of the executed demand (fraction of the pedal range)
    demand_noise_std: float = ranged(0.05, ge=0.0, le=1.0)
    epochs: int = ranged(30, ge=1, le=1000, integer=True)  # passes over the data per round
    batch_size: int = ranged(1024, ge=16, le=10**6, integer=True)
    learning_rate: float = ranged(1e-3, ge=1e-6, le=1.0)
    init_log_std: float = ranged(-3.0, ge=-10.0, le=1.0)  # log of the exploration std after the warm start
    # SAC: critic-only gradient steps on the prefilled buffer before RL starts
    critic_steps: int = ranged(5000, ge=0, le=10**7, integer=True)

    def __post_init__(self) -> None:
        validate(self)
        if not isinstance(self.expert, str) or not self.expert:
            raise ValueError(f"BCConfig.expert must be a baseline name (got {self.expert!r})")
        if not isinstance(self.expert_preset, str) or not self.expert_preset:
            raise ValueError(f"BCConfig.expert_preset must be a preset name (got {self.expert_preset!r})")

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass
class ExpertData:
    """Transitions, time-major: ``obs`` (T, n, obs_dim) raw, ``label`` (T, n, action_dim) the expert's action
    (``collect``'s; (T, n) is read as one entry per action), ``executed`` the same shape, the perturbed action
    applied, ``reward``/``done`` (T, n), ``next_obs`` (T, n, obs_dim) (the terminal
    observation at an episode end), and how the episodes that ended did."""

    obs: np.ndarray
    label: np.ndarray
    executed: np.ndarray
    reward: np.ndarray
    done: np.ndarray
    next_obs: np.ndarray
    terminations: dict[str, int]
    truncated: np.ndarray | None = None   # (T, n) bool: the episode ended at its time limit (not a true terminal)

    @property
    def transitions(self) -> int:
        return int(self.label.shape[0] * self.label.shape[1])   # (T, n[, action_dim]): one per car and step


def collect(venv: Any, config: BCConfig, seed: int = 0, driver: Any = None) -> ExpertData:
    """Drive ``venv`` (a ``TrackingSB3VecEnv``) for ``config.steps`` vector steps with the expert, or with
    ``driver`` (a ``predict(obs)`` policy: the DAgger rounds) if given; the labels are always the expert's.

    The expert is ``make_policy(config.expert, venv)``: in a longitudinal control mode the steering law paired with
    the PD-FLC (``baselines.decoupled``), whose labels are ``[steering, demand]``. The steering entry gets the
    AR(1) perturbation of ``noise_std`` (falling as 1/v^2 above 10 m/s), the demand entry one of
    ``demand_noise_std`` (constant: a fraction of the pedal range)."""
    from vtrack_gym.baselines.registry import make_policy
    from vtrack_gym.envs.observation import OBS

    expert = make_policy(config.expert, venv, preset=config.expert_preset)
    n, dim = venv.num_envs, int(venv.action_space.shape[0])
    rng = np.random.default_rng(seed)
    rho = math.exp(-venv.get_attr("control_period_s")[0] / config.noise_corr_s) if config.noise_corr_s > 0 else 0.0
    venv.seed(seed)
    obs = venv.reset()
    state, starts = None, np.ones(n, dtype=bool)
    noise = np.zeros((n, dim))
    std = np.array([config.noise_std] + [config.demand_noise_std] * (dim - 1))
    shape = (config.steps, n)
    data = ExpertData(np.empty((*shape, obs.shape[1]), np.float32), np.empty((*shape, dim), np.float32),
                      np.empty((*shape, dim), np.float32), np.empty(shape, np.float32), np.empty(shape, bool),
                      np.empty((*shape, obs.shape[1]), np.float32), {}, np.zeros(shape, bool))
    for t in range(config.steps):
        action, state = expert.predict(obs, state, episode_start=starts)
        label = np.asarray(action, dtype=np.float32).reshape(n, dim)
        base = label if driver is None else np.asarray(driver.predict(obs)[0], dtype=np.float32).reshape(n, dim)
        noise = rho * noise + math.sqrt(1.0 - rho * rho) * std * rng.standard_normal((n, dim))
        scale = np.ones((n, dim))
        scale[:, 0] = (NOISE_REFERENCE_SPEED_MPS / np.maximum(obs[:, OBS.V_X], NOISE_REFERENCE_SPEED_MPS)) ** 2
        executed = np.clip(base + noise * scale, -1.0, 1.0).astype(np.float32)
        next_obs, reward, done, infos = venv.step(executed)
        data.obs[t], data.label[t], data.executed[t], data.reward[t], data.done[t] = obs, label, executed, reward, done
        data.next_obs[t] = next_obs
        for i in np.flatnonzero(done):
            data.next_obs[t, i] = infos[i]["terminal_observation"]
            data.truncated[t, i] = bool(infos[i].get("TimeLimit.truncated", False))
            name = str(infos[i].get("termination") or "time_limit")
            data.terminations[name] = data.terminations.get(name, 0) + 1
        obs, starts = next_obs, done
    return data


def discounted_returns(reward: np.ndarray, done: np.ndarray, gamma: float) -> np.ndarray:
    """Monte-Carlo returns (T, n) summed backwards, cut at episode ends (no bootstrap at the data's end)."""
    out = np.zeros_like(reward, dtype=np.float64)
    acc = np.zeros(reward.shape[1])
    for t in range(reward.shape[0] - 1, -1, -1):
        acc = reward[t] + gamma * acc * (~done[t])
        out[t] = acc
    return out


def _set_obs_statistics(vecnorm: Any, obs: np.ndarray) -> None:
    """Set ``vecnorm``'s running observation statistics to the mean and variance of ``obs`` (raw, SI units);
    frozen fixed scales (``obs_scaling.FrozenStatistics``) are left unchanged, so the agent keeps them."""
    from vtrack_gym.agents.obs_scaling import FrozenStatistics

    if isinstance(vecnorm.obs_rms, FrozenStatistics):
        return
    flat = obs.reshape(-1, obs.shape[-1]).astype(np.float64)
    vecnorm.obs_rms.mean = flat.mean(axis=0)
    vecnorm.obs_rms.var = flat.var(axis=0)
    vecnorm.obs_rms.count = float(flat.shape[0])


def _set_return_statistics(vecnorm: Any, reward: np.ndarray, done: np.ndarray, gamma: float) -> None:
    """VecNormalize's running discounted return (ret = ret * gamma + r, reset at done) over the data."""
    ret = np.zeros(reward.shape[1])
    seen = np.empty_like(reward, dtype=np.float64)
    for t in range(reward.shape[0]):
        ret = ret * gamma + reward[t]
        seen[t] = ret
        ret[done[t]] = 0.0
    vecnorm.ret_rms.mean = float(seen.mean())
    vecnorm.ret_rms.var = float(seen.var())
    vecnorm.ret_rms.count = float(seen.size)


def _fit(params: list[Any], predict: Any, inputs: Any, targets: Any, config: BCConfig, seed: int,
         weights: Any = None) -> float:
    """Minimise the MSE of ``predict(inputs[batch])`` against ``targets[batch]`` (each error times its entry of
    ``weights[batch]``, (N, outputs), if given); returns the last epoch's loss."""
    import torch

    opt = torch.optim.Adam(params, lr=config.learning_rate)
    gen = torch.Generator().manual_seed(seed)
    n = inputs.shape[0]
    loss_sum = 0.0
    for _ in range(config.epochs):
        perm = torch.randperm(n, generator=gen)
        loss_sum, batches = 0.0, 0
        for start in range(0, n, config.batch_size):
            idx = perm[start:start + config.batch_size]
            error = predict(inputs[idx]) - targets[idx]
            loss = torch.mean((error if weights is None else error * weights[idx]) ** 2)
            opt.zero_grad()
            loss.backward()
            opt.step()
            loss_sum += float(loss.detach())
            batches += 1
        loss_sum /= max(batches, 1)
    return loss_sum


def _actor(model: Any) -> tuple[Any, list[Any]]:
    """(deterministic action of normalised observations, its parameters) of a PPO or SAC model."""
    import torch
    from stable_baselines3 import PPO, SAC

    policy = model.policy
    if isinstance(model, PPO):
        def act(x: Any) -> Any:
            return policy.action_net(policy.mlp_extractor.forward_actor(policy.extract_features(x)))

        return act, [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters()]
    if isinstance(model, SAC):
        actor = model.actor

        def act(x: Any) -> Any:
            return torch.tanh(actor.mu(actor.latent_pi(actor.extract_features(x, actor.features_extractor))))

        return act, [*actor.latent_pi.parameters(), *actor.mu.parameters()]
    raise ValueError(f"the behaviour-cloning warm start supports PPO and SAC (got {type(model).__name__})")


def _action_dim(data: ExpertData) -> int:
    """Entries of one action in ``data`` (1 for labels stored as (T, n), the steering-only layout)."""
    return int(data.label.shape[2]) if data.label.ndim == 3 else 1


def labelled_states(rounds: list[ExpertData]) -> tuple[np.ndarray, np.ndarray]:
    """All rounds' raw observations (N, obs_dim) and the expert's labels for them (N, action_dim)."""
    obs = np.concatenate([d.obs.reshape(-1, d.obs.shape[-1]) for d in rounds])
    return obs, np.concatenate([d.label.reshape(-1, _action_dim(d)) for d in rounds])


LATERAL_FIELDS = frozenset({"e_y", "e_phi", "e_y_dot", "e_phi_dot", "v_y", "yaw_rate", "road_wheel_angle",
                            "yaw_rate_ref", "yaw_acc_ref", "curvature", "curvature_rate"})
"""Observation fields that change sign in the mirror image of a state (left and right swapped); so do the
``kappa_preview_*`` fields. The others (speeds, speed and time errors, speed preview) keep theirs."""
LONGITUDINAL_FIELDS = frozenset({"v_x", "target_speed", "speed_error", "time_error"})
"""Observation fields a mirror image leaves unchanged (with the ``v_ref_preview_*`` fields)."""


def _layout_names(vecnorm: Any) -> tuple[str, ...] | None:
    """The observation layout's field names of the env under ``vecnorm`` (None if it has none)."""
    env = vecnorm
    while env is not None and not hasattr(env, "observation_layout"):
        env = getattr(env, "venv", None)
    return None if env is None else tuple(env.observation_layout.names)


def mirrored(obs: np.ndarray, label: np.ndarray, names: tuple[str, ...] | None) -> tuple[np.ndarray, np.ndarray]:
    """``obs`` (N, obs_dim) and ``label`` (N, outputs) with their mirror images appended: lateral fields and the
    steering output (entry 0) negated, the rest kept, so the clone steers straight on a straight road at any speed
    (a data set drawn mostly at low speed otherwise leaves a bias where it extrapolates). Unchanged when a field of
    ``names`` is neither lateral nor longitudinal (a layout this function does not know)."""
    if names is None:
        return obs, label
    odd = np.array([n in LATERAL_FIELDS or n.startswith("kappa_preview_") for n in names])
    even = np.array([n in LONGITUDINAL_FIELDS or n.startswith("v_ref_preview_") for n in names])
    if not np.all(odd | even) or len(names) != obs.shape[1]:
        return obs, label
    sign = np.where(odd, -1.0, 1.0).astype(obs.dtype)
    flip = np.ones(label.shape[1], dtype=label.dtype)
    flip[0] = -1.0
    return np.concatenate([obs, obs * sign]), np.concatenate([label, label * flip])


def _output_weights(obs: np.ndarray, label: np.ndarray) -> np.ndarray:
    """(N, action_dim) weights of a several-output clone's errors: each output's error in its own spread (steering
    ~0.01-0.1, demand ~0.1-1), and the steering error also times (v / 10 m/s)^2 above 10 m/s (what a steering error
    does to the path grows as v^2, as the perturbation falls in ``collect``), rescaled to a mean of 1."""
    from vtrack_gym.envs.observation import OBS

    weights = np.tile(1.0 / np.maximum(label.std(axis=0), 1e-3), (label.shape[0], 1))
    speed = (np.maximum(obs[:, OBS.V_X], NOISE_REFERENCE_SPEED_MPS) / NOISE_REFERENCE_SPEED_MPS) ** 2
    weights[:, 0] *= np.sqrt(speed / speed.mean())   # squared in the loss
    return weights


def _clone(model: Any, vecnorm: Any, rounds: list[ExpertData], config: BCConfig, seed: int) -> float:
    """Fit the actor to the expert labels of all ``rounds`` (running observation statistics from the same data;
    fixed scales are kept). With several outputs (the longitudinal modes) the data get their mirror image
    (``mirrored``) and the errors are weighted (``_output_weights``): the small steering commands weigh as much as
    the demand, and more at speed."""
    import torch

    obs, label = labelled_states(rounds)
    if label.shape[1] > 1:   # the longitudinal modes: the data and their mirror image
        obs, label = mirrored(obs, label, _layout_names(vecnorm))
    _set_obs_statistics(vecnorm, obs)
    act, params = _actor(model)
    x = torch.as_tensor(vecnorm.normalize_obs(obs), dtype=torch.float32)
    y = torch.as_tensor(label, dtype=torch.float32)
    weights = None
    if label.shape[1] > 1:
        weights = torch.as_tensor(_output_weights(obs, label), dtype=torch.float32)
    model.policy.set_training_mode(True)
    mse = _fit(params, act, x, y, config, seed, weights)
    model.policy.set_training_mode(False)
    if weights is not None:  # the record keeps the plain MSE [action units^2]
        with torch.no_grad():
            mse = float(torch.mean((act(x) - y) ** 2))
    return mse


class _Clone:
    """The model being cloned as a ``predict(raw obs)`` driver for the DAgger rounds."""

    def __init__(self, model: Any, vecnorm: Any) -> None:
        self.model, self.vecnorm = model, vecnorm

    def predict(self, obs: np.ndarray) -> tuple[np.ndarray, None]:
        action, _ = self.model.predict(self.vecnorm.normalize_obs(obs), deterministic=True)
        return action, None


def warm_start(model: Any, venv: Any, vecnorm: Any, config: BCConfig, seed: int = 0) -> tuple[list[ExpertData],
                                                                                             dict[str, Any]]:
    """Collect the expert data (plus the DAgger rounds), clone it into ``model``'s actor and, for PPO, fit the
    value function (see the module docstring). Returns (the data of every round, a JSON-safe record of the fit:
    ``actor_mse`` per round in action units^2, PPO's ``value_mse`` in normalised return units^2)."""
    import torch
    from stable_baselines3 import PPO, SAC

    rounds = [collect(venv, config, seed=seed)]
    record: dict[str, Any] = {"actor_mse": [_clone(model, vecnorm, rounds, config, seed)]}
    for k in range(config.dagger_rounds):
        rounds.append(collect(venv, config, seed=seed + 1 + k, driver=_Clone(model, vecnorm)))
        record["actor_mse"].append(_clone(model, vecnorm, rounds, config, seed + 1 + k))
    record["terminations"] = [d.terminations for d in rounds]
    policy = model.policy
    if isinstance(model, PPO):
        with torch.no_grad():
            policy.log_std.fill_(config.init_log_std)
        last = rounds[-1]
        if vecnorm.norm_reward:
            _set_return_statistics(vecnorm, last.reward, last.done, model.gamma)
        returns = discounted_returns(last.reward, last.done, model.gamma)
        tail = min(int(3.0 / (1.0 - model.gamma)), last.reward.shape[0] // 2)  # returns cut short at the data's end
        scale = 1.0 / math.sqrt(vecnorm.ret_rms.var + vecnorm.epsilon) if vecnorm.norm_reward else 1.0
        keep = slice(0, last.reward.shape[0] - tail)
        v_obs = torch.as_tensor(vecnorm.normalize_obs(last.obs[keep].reshape(-1, last.obs.shape[-1])),
                                dtype=torch.float32)
        v_target = torch.as_tensor((returns[keep] * scale).reshape(-1, 1), dtype=torch.float32)

        def critic(x: Any) -> Any:
            return policy.value_net(policy.mlp_extractor.forward_critic(policy.extract_features(x)))

        params = [*policy.mlp_extractor.value_net.parameters(), *policy.value_net.parameters()]
        policy.set_training_mode(True)
        record["value_mse"] = _fit(params, critic, v_obs, v_target, config, seed + 100)
        policy.set_training_mode(False)
    elif isinstance(model, SAC) and isinstance(model.actor.log_std, torch.nn.Linear):
        with torch.no_grad():  # start with a small exploration std, as for PPO
            model.actor.log_std.weight.zero_()
            model.actor.log_std.bias.fill_(config.init_log_std)
    return rounds, record


def prefill_replay_buffer(model: Any, rounds: list[ExpertData]) -> int:
    """Put the collected transitions (executed actions, raw observations) into an off-policy model's replay
    buffer, time-limit ends marked as SB3 marks them (``TimeLimit.truncated``); returns how many were added."""
    buf = model.replay_buffer
    added = 0
    for data in rounds:
        n = data.label.shape[1]
        for t in range(data.label.shape[0]):
            # SB3 stores a time-limit end as a timeout, bootstrapped like a running episode, not a true terminal
            infos = [{"TimeLimit.truncated": bool(data.truncated is not None and data.truncated[t, i])}
                     for i in range(n)]
            buf.add(data.obs[t], data.next_obs[t], data.executed[t].reshape(n, _action_dim(data)), data.reward[t],
                    data.done[t], infos)
        added += data.transitions
    return added


def pretrain_critic(model: Any, gradient_steps: int, batch_size: int = 256) -> float:
    """Train an SAC model's critics (and their target copies) on its replay buffer with the actor and the
    entropy coefficient frozen (soft Bellman targets, ``regularised_sac.critic_step``). Returns the last
    batch's critic loss."""
    import torch
    from stable_baselines3.common.utils import polyak_update

    from vtrack_gym.agents.regularised_sac import critic_step

    if model.ent_coef_optimizer is not None:
        alpha = torch.exp(model.log_ent_coef.detach())
    else:
        alpha = model.ent_coef_tensor
    model.policy.set_training_mode(True)
    loss_value = float("nan")
    for _ in range(gradient_steps):
        batch = model.replay_buffer.sample(batch_size, env=model._vec_normalize_env)
        loss_value = critic_step(model, batch, alpha)
        polyak_update(model.critic.parameters(), model.critic_target.parameters(), model.tau)
    model.policy.set_training_mode(False)
    return loss_value
