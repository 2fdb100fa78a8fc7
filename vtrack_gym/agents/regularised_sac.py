"""SAC with extra actor-loss terms: behaviour cloning (fine-tuning a warm-started actor) and action smoothness.

Plain SAC forgets a cloned actor within a few hundred gradient steps here: nothing keeps the actor near the
demonstrations while the critic is still wrong about them, and on this task a steering change of 1 % of the
range at 120 km/h is already a lane's width of error. Following TD3+BC (Fujimoto & Gu, 2021), the actor loss
adds a regression of the deterministic action on the demonstrated one and scales the RL part by the batch's
mean |Q| so that ``bc_weight`` means the same whatever the reward's scale:

    L_actor = E_s[alpha log pi(a|s) - min_j Q_j(s, a)] / E_s|min_j Q_j(s, a)|  +  bc_weight E_d[(mu(s_d) - a_d)^2]

with ``a ~ pi(.|s)`` on a replay batch, ``mu`` the deterministic (tanh-squashed mean) action and ``(s_d, a_d)``
a batch of the expert's labelled states (the warm start's data, observations normalised like the replay
buffer's). ``bc_weight = 0`` is SAC's actor loss up to the positive per-batch factor. The critic and the
entropy coefficient are updated as in SAC (soft Bellman targets, twin critics, Polyak-averaged targets).

Action smoothness (CAPS, Mysore et al., 2021, with squared distances): a SAC actor trained on this task from
scratch flicks its deterministic steering between left and right at every decision (64 reversals/s on DLC120-v0),
which the rate-limited actuator and the reward's bounded rate term do not stop, because the exploration noise
costs the same rate penalty whatever the mean does. Two terms act on the mean action itself:

    + temporal_smoothness E[(mu(s) - mu(s'))^2]  +  spatial_smoothness E[(mu(s) - mu(s + spatial_noise eps))^2]

with ``s'`` the replay batch's successor states (SB3 stores the true final observation at an episode's end) and
``eps ~ N(0, I)`` in the normalised observation's units (with the fixed scaling 0.05 is 1.25 cm of e_y, 5 mrad of
e_phi). Squared, not CAPS's plain distances: a change of 0.07 of the range per 50 ms decision (the nominal
actuator's full rate) costs 0.005 x weight, a flick of 0.6 costs 0.36 x weight.

The model saves and loads as an ordinary SB3 ``SAC`` (``SAC.load`` reads its zip; ``RegularisedSAC.load``
also restores the terms' weights); the demonstrations are not saved with it, so a resumed run must call
``set_demonstrations`` again (it warns if it was not).
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
from stable_baselines3 import SAC


def soft_bellman_target(model: SAC, batch: Any, alpha: Any) -> Any:
    """``r + discount (1 - done) (min_j Q'_j(s', a') - alpha log pi(a'|s'))`` with ``a' ~ pi(.|s')`` (no grad)."""
    import torch

    with torch.no_grad():
        next_a, next_logp = model.actor.action_log_prob(batch.next_observations)
        next_q = torch.cat(model.critic_target(batch.next_observations, next_a), dim=1)
        next_q = torch.min(next_q, dim=1, keepdim=True)[0] - alpha * next_logp.reshape(-1, 1)
        discount = getattr(batch, "discounts", None)
        discount = model.gamma if discount is None else discount
        return batch.rewards + (1.0 - batch.dones) * discount * next_q


def critic_step(model: SAC, batch: Any, alpha: Any) -> float:
    """One gradient step of the twin critics on ``batch``; returns the loss (sum of the halved MSEs)."""
    import torch.nn.functional as F

    target = soft_bellman_target(model, batch, alpha)
    loss = 0.5 * sum(F.mse_loss(q, target) for q in model.critic(batch.observations, batch.actions))
    model.critic.optimizer.zero_grad()
    loss.backward()
    model.critic.optimizer.step()
    return float(loss.detach())


def _non_negative(name: str, value: Any) -> float:
    if isinstance(value, bool) or not (isinstance(value, (int, float)) and np.isfinite(value) and value >= 0.0):
        raise ValueError(f"{name} must be a finite number >= 0 (got {value!r})")
    return float(value)


class RegularisedSAC(SAC):
    """``SAC`` whose actor loss adds TD3+BC's behaviour-cloning term and CAPS-style smoothness terms (see the
    module docstring). For the BC term call ``set_demonstrations`` before ``learn``; without demonstrations (or
    with ``bc_weight = 0``) and with zero smoothness weights the actor follows the normalised SAC loss.

    ``temporal_smoothness``, ``spatial_smoothness``: weights (>= 0, dimensionless: the SAC part is divided by the
    batch's mean |Q|); ``spatial_noise``: standard deviation of the state perturbation in normalised observation
    units (> 0). ``actor_delay_steps``: env steps during which only the critics learn (the actor and the
    entropy coefficient are held: a critic warm-up on the data of a loaded actor)."""

    def __init__(self, *args: Any, bc_weight: float = 0.0, bc_batch_size: int = 256,
                 temporal_smoothness: float = 0.0, spatial_smoothness: float = 0.0, spatial_noise: float = 0.05,
                 actor_delay_steps: int = 0, **kwargs: Any) -> None:
        bc_weight = _non_negative("bc_weight", bc_weight)
        if isinstance(actor_delay_steps, bool) or not isinstance(actor_delay_steps, int) or actor_delay_steps < 0:
            raise ValueError(f"actor_delay_steps must be an int >= 0 (got {actor_delay_steps!r})")
        self.actor_delay_steps = int(actor_delay_steps)
        if isinstance(bc_batch_size, bool) or not isinstance(bc_batch_size, int) or bc_batch_size < 1:
            raise ValueError(f"bc_batch_size must be a positive int (got {bc_batch_size!r})")
        self.temporal_smoothness = _non_negative("temporal_smoothness", temporal_smoothness)
        self.spatial_smoothness = _non_negative("spatial_smoothness", spatial_smoothness)
        self.spatial_noise = _non_negative("spatial_noise", spatial_noise)
        if self.spatial_noise == 0.0:
            raise ValueError("spatial_noise must be a finite number > 0 (got 0)")
        self.bc_weight = float(bc_weight)
        self.bc_batch_size = int(bc_batch_size)
        self._demo_obs: np.ndarray | None = None
        self._demo_actions: np.ndarray | None = None
        self._demo_rng = np.random.default_rng()
        self._warned_no_demo = False
        super().__init__(*args, **kwargs)

    def _excluded_save_params(self) -> list[str]:
        # the weights and bc_batch_size are saved (RegularisedSAC.load restores them); the data are not
        return [*super()._excluded_save_params(), "_demo_obs", "_demo_actions", "_demo_rng",
                "_warned_no_demo"]

    def set_demonstrations(self, observations: np.ndarray, actions: np.ndarray) -> None:
        """Expert-labelled states: raw observations (N, obs_dim) and actions (N, act_dim) in [-1, 1]."""
        obs = np.asarray(observations, dtype=np.float32)
        act = np.asarray(actions, dtype=np.float32)
        obs_dim, act_dim = self.observation_space.shape[0], self.action_space.shape[0]
        if obs.ndim != 2 or obs.shape[0] == 0 or obs.shape[1] != obs_dim:
            raise ValueError(f"demonstration observations must have shape (N >= 1, {obs_dim}) (got {obs.shape})")
        if act.size != obs.shape[0] * act_dim:
            raise ValueError(f"demonstration actions must have shape ({obs.shape[0]}, {act_dim}) (got {act.shape})")
        act = act.reshape(obs.shape[0], act_dim)
        if not (np.all(np.isfinite(obs)) and np.all(np.isfinite(act))):
            raise ValueError("demonstrations must be finite (NaN/inf found)")
        if np.any(np.abs(act) > 1.0):
            raise ValueError("demonstration actions must lie in [-1, 1] (the normalised steering range)")
        self._demo_obs, self._demo_actions = obs, act
        self._demo_rng = np.random.default_rng(self.seed)  # the model's seed: a rerun draws the same batches

    def _demo_batch(self) -> tuple[Any, Any] | None:
        import torch

        if self.bc_weight == 0.0:
            return None
        if self._demo_obs is None:
            if not self._warned_no_demo:
                warnings.warn("RegularisedSAC has bc_weight > 0 but no demonstrations (set_demonstrations was "
                              "not called, e.g. after load): training with the normalised SAC loss alone",
                              stacklevel=3)
                self._warned_no_demo = True
            return None
        idx = self._demo_rng.integers(0, self._demo_obs.shape[0], size=self.bc_batch_size)
        obs = self._demo_obs[idx]
        if self._vec_normalize_env is not None:
            obs = self._vec_normalize_env.normalize_obs(obs)
        return (torch.as_tensor(obs, dtype=torch.float32, device=self.device),
                torch.as_tensor(self._demo_actions[idx], device=self.device))

    def _deterministic_action(self, obs: Any) -> Any:
        import torch

        mean, _, _ = self.actor.get_action_dist_params(obs)
        return torch.tanh(mean)

    def _alpha(self, log_prob: Any) -> tuple[Any, float | None]:
        """(entropy coefficient for this step, its loss if it is learned); takes the coefficient's step."""
        import torch

        if self.ent_coef_optimizer is None or self.log_ent_coef is None:
            return self.ent_coef_tensor, None
        alpha = torch.exp(self.log_ent_coef.detach())
        loss = -(self.log_ent_coef * (log_prob + self.target_entropy).detach()).mean()
        self.ent_coef_optimizer.zero_grad()
        loss.backward()
        self.ent_coef_optimizer.step()
        return alpha, float(loss.detach())

    def _held_alpha(self) -> Any:
        """The entropy coefficient as it is (no step)."""
        import torch

        if self.ent_coef_optimizer is None or self.log_ent_coef is None:
            return self.ent_coef_tensor
        return torch.exp(self.log_ent_coef.detach())

    def _smoothness_loss(self, batch: Any, log: dict[str, list[float]]) -> Any:
        """The weighted temporal and spatial smoothness terms of the batch (0 when both weights are 0)."""
        import torch

        loss = torch.zeros((), device=self.device)
        if self.temporal_smoothness == 0.0 and self.spatial_smoothness == 0.0:
            return loss
        mu = self._deterministic_action(batch.observations)
        if self.temporal_smoothness > 0.0:
            temporal = torch.mean((mu - self._deterministic_action(batch.next_observations)) ** 2)
            loss = loss + self.temporal_smoothness * temporal
            log["temporal_mse"].append(float(temporal.detach()))
        if self.spatial_smoothness > 0.0:
            noisy = batch.observations + self.spatial_noise * torch.randn_like(batch.observations)
            spatial = torch.mean((mu - self._deterministic_action(noisy)) ** 2)
            loss = loss + self.spatial_smoothness * spatial
            log["spatial_mse"].append(float(spatial.detach()))
        return loss

    def _actor_critic_step(self, batch: Any, log: dict[str, list[float]]) -> None:
        """One step of the entropy coefficient, the critics and the actor on ``batch``; appends to ``log``."""
        import torch

        actions_pi, log_prob = self.actor.action_log_prob(batch.observations)
        log_prob = log_prob.reshape(-1, 1)
        alpha, alpha_loss = self._alpha(log_prob)
        log["ent_coef"].append(float(alpha))
        if alpha_loss is not None:
            log["ent_coef_loss"].append(alpha_loss)
        log["critic_loss"].append(critic_step(self, batch, alpha))

        q_pi = torch.min(torch.cat(self.critic(batch.observations, actions_pi), dim=1), dim=1, keepdim=True)[0]
        loss = (alpha * log_prob - q_pi).mean() / q_pi.abs().mean().detach().clamp_min(1e-6)
        demo = self._demo_batch()
        if demo is not None:
            bc_mse = torch.mean((self._deterministic_action(demo[0]) - demo[1]) ** 2)
            loss = loss + self.bc_weight * bc_mse
            log["bc_mse"].append(float(bc_mse.detach()))
        loss = loss + self._smoothness_loss(batch, log)
        self.actor.optimizer.zero_grad()
        loss.backward()
        self.actor.optimizer.step()
        log["actor_loss"].append(float(loss.detach()))

    def train(self, gradient_steps: int, batch_size: int = 64) -> None:
        from stable_baselines3.common.utils import polyak_update

        self.policy.set_training_mode(True)
        optimizers = [self.actor.optimizer, self.critic.optimizer]
        if self.ent_coef_optimizer is not None:
            optimizers.append(self.ent_coef_optimizer)
        self._update_learning_rate(optimizers)
        log: dict[str, list[float]] = {"ent_coef": [], "actor_loss": [], "critic_loss": [], "bc_mse": [],
                                       "ent_coef_loss": [], "temporal_mse": [], "spatial_mse": []}
        for step in range(gradient_steps):
            batch = self.replay_buffer.sample(batch_size, env=self._vec_normalize_env)  # type: ignore[union-attr]
            if self.use_sde:  # as SB3's SAC: a new exploration matrix for every gradient step
                self.actor.reset_noise()
            if self.num_timesteps < self.actor_delay_steps:  # critic warm-up: the actor drives as it is
                log["critic_loss"].append(critic_step(self, batch, self._held_alpha()))
            else:
                self._actor_critic_step(batch, log)
            if step % self.target_update_interval == 0:
                polyak_update(self.critic.parameters(), self.critic_target.parameters(), self.tau)
                polyak_update(self.batch_norm_stats, self.batch_norm_stats_target, 1.0)
        self._n_updates += gradient_steps
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        for key, values in log.items():
            if values:
                self.logger.record(f"train/{key}", float(np.mean(values)))
