"""RegularisedSAC: its BC term pulls the actor to the demonstrations, its smoothness terms flatten the actor, it
saves/loads as plain SAC, bad input."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
torch = pytest.importorskip("torch")
torch.set_num_threads(1)


def _model(bc_weight: float, seed: int = 0, **kwargs):
    from stable_baselines3.common.vec_env import VecNormalize

    from vtrack_gym.agents.regularised_sac import RegularisedSAC
    from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv

    venv = TrackingSB3VecEnv("LateralTrackingRandom-v0", num_envs=4)
    venv.seed(seed)
    vecnorm = VecNormalize(venv, norm_obs=True, norm_reward=False)
    params = {"learning_starts": 0, "buffer_size": 5000, "batch_size": 64, "learning_rate": 3e-3,
              "policy_kwargs": {"net_arch": [32, 32]}, **kwargs}
    return RegularisedSAC("MlpPolicy", vecnorm, bc_weight=bc_weight, seed=seed, device="cpu", **params), venv


def _demo(venv, n: int = 400, target: float = 0.3) -> tuple[np.ndarray, np.ndarray]:
    obs = venv.reset()
    rows = [obs]
    for _ in range(n // obs.shape[0] - 1):
        obs, *_ = venv.step(np.zeros((venv.num_envs, 1), dtype=np.float32))
        rows.append(obs)
    states = np.concatenate(rows)
    return states, np.full((states.shape[0], 1), target, dtype=np.float32)


def _mean_demo_action(model, states: np.ndarray) -> float:
    action, _ = model.predict(model.get_vec_normalize_env().normalize_obs(states), deterministic=True)
    return float(np.mean(action))


def test_bc_term_pulls_the_actor_to_the_demonstrated_action():
    """Demonstrations that all say 0.3: with a strong BC weight the deterministic action goes there."""
    model, venv = _model(100.0)
    states, labels = _demo(venv)
    model.set_demonstrations(states, labels)
    model.learn(total_timesteps=600)  # 150 vector steps, 150 gradient steps
    assert abs(_mean_demo_action(model, states) - 0.3) < 0.05
    assert model.logger.name_to_value["train/bc_mse"] < 0.01
    venv.close()


def test_with_zero_weight_the_labels_do_not_matter():
    """bc_weight = 0: demonstrations saying +0.3 or -0.3 give the same agent (the BC term is off)."""
    actions = []
    for target in (0.3, -0.3):
        model, venv = _model(0.0)
        states, labels = _demo(venv, target=target)
        model.set_demonstrations(states, labels)
        model.learn(total_timesteps=200)
        actions.append(model.predict(model.get_vec_normalize_env().normalize_obs(states), deterministic=True)[0])
        assert "train/bc_mse" not in model.logger.name_to_value
        venv.close()
    np.testing.assert_array_equal(actions[0], actions[1])


@pytest.mark.parametrize("use_sde", [False, True])
def test_one_update_matches_stock_sac(use_sde: bool):
    """From the same weights, buffer and sampling RNG, one gradient step updates the critics and the entropy
    coefficient exactly as SB3's SAC does, and (bc_weight = 0) the actor's gradient is SAC's divided by one
    positive number (the batch's mean |Q|); with gSDE too (a new exploration matrix per gradient step)."""
    from stable_baselines3 import SAC

    from vtrack_gym.agents.sb3_logger import quiet_logger

    ours, venv = _model(0.0, use_sde=use_sde)
    stock = SAC("MlpPolicy", ours.get_env(), seed=0, device="cpu", learning_starts=0, buffer_size=5000,
                batch_size=64, learning_rate=3e-3, policy_kwargs={"net_arch": [32, 32]}, use_sde=use_sde)
    stock.policy.load_state_dict(ours.policy.state_dict())
    with torch.no_grad():
        stock.log_ent_coef.copy_(ours.log_ent_coef)
    rng = np.random.default_rng(1)
    obs = venv.reset()
    for _ in range(50):
        act = rng.uniform(-1, 1, size=(venv.num_envs, 1)).astype(np.float32)
        nxt, rew, done, infos = venv.step(act)
        for m in (ours, stock):
            m.replay_buffer.add(obs, nxt, act, rew, done, infos)
        obs = nxt
    for m in (ours, stock):
        m.set_logger(quiet_logger())   # SB3's configure(None, ...) would make a folder in $TMPDIR
        np.random.seed(7)  # noqa: NPY002 (SB3's replay buffer samples with the legacy global RNG)
        torch.manual_seed(7)
        m.train(gradient_steps=1, batch_size=64)
    for a, b in zip(ours.critic.parameters(), stock.critic.parameters(), strict=True):
        torch.testing.assert_close(a, b, rtol=0, atol=0)
    torch.testing.assert_close(ours.log_ent_coef, stock.log_ent_coef, rtol=0, atol=0)
    g_ours = torch.cat([p.grad.flatten() for p in ours.actor.parameters() if p.grad is not None])
    g_stock = torch.cat([p.grad.flatten() for p in stock.actor.parameters() if p.grad is not None])
    scale = float(g_ours @ g_stock / (g_ours @ g_ours))
    assert scale > 0.0  # the batch's mean |Q| (small: the critics are untrained)
    torch.testing.assert_close(g_ours * scale, g_stock, rtol=1e-4, atol=1e-7)
    venv.close()


def test_saves_and_loads(tmp_path):
    """SAC.load reads the zip; RegularisedSAC.load restores bc_weight; the demonstrations are not saved and
    training a loaded model without them warns."""
    import json
    import zipfile

    from stable_baselines3 import SAC

    from vtrack_gym.agents.regularised_sac import RegularisedSAC

    model, venv = _model(7.0)
    states, labels = _demo(venv, n=80)
    model.set_demonstrations(states, labels)
    model.learn(total_timesteps=200)
    model.save(tmp_path / "m.zip")
    with zipfile.ZipFile(tmp_path / "m.zip") as zf:
        data = json.loads(zf.read("data"))
    assert "_demo_obs" not in data and "_demo_actions" not in data and "bc_weight" in data
    x = model.get_vec_normalize_env().normalize_obs(states)
    loaded = SAC.load(tmp_path / "m.zip", device="cpu")
    np.testing.assert_array_equal(model.predict(x, deterministic=True)[0], loaded.predict(x, deterministic=True)[0])
    resumed = RegularisedSAC.load(tmp_path / "m.zip", env=model.get_env(), device="cpu")
    assert resumed.bc_weight == 7.0 and resumed._demo_obs is None
    with pytest.warns(UserWarning, match="no demonstrations"):
        resumed.learn(total_timesteps=100)
    venv.close()


def _transitions(venv, steps: int = 60) -> tuple[np.ndarray, np.ndarray]:
    """(states, successor states) of a random-steering drive (episode ends excluded)."""
    rng = np.random.default_rng(3)
    obs = venv.reset()
    now, nxt = [], []
    for _ in range(steps):
        new, _, done, _ = venv.step(rng.uniform(-1, 1, size=(venv.num_envs, 1)).astype(np.float32))
        now.append(obs[~done])
        nxt.append(new[~done])
        obs = new
    return np.concatenate(now), np.concatenate(nxt)


def _action_variation(model, states: np.ndarray, successors: np.ndarray) -> tuple[float, float]:
    """(spread of the deterministic action over the states, its mean change from a state to its successor)."""
    norm = model.get_vec_normalize_env().normalize_obs
    a = model.predict(norm(states), deterministic=True)[0]
    b = model.predict(norm(successors), deterministic=True)[0]
    return float(np.std(a)), float(np.mean(np.abs(a - b)))


def test_smoothness_terms_flatten_the_actor():
    """Same seed, same data stream: with strong temporal and spatial weights the deterministic action varies far
    less over the visited states, and changes less from a state to its successor, than with the terms off; the
    terms' MSEs are logged only when on."""
    variation = {}
    for weight in (0.0, 50.0):
        model, venv = _model(0.0, temporal_smoothness=weight, spatial_smoothness=weight, spatial_noise=0.5)
        model.learn(total_timesteps=800)  # 200 vector steps, 200 gradient steps
        logged = model.logger.name_to_value
        assert ("train/temporal_mse" in logged) == ("train/spatial_mse" in logged) == (weight > 0.0)
        variation[weight] = _action_variation(model, *_transitions(venv))
        venv.close()
    (spread_off, change_off), (spread_on, change_on) = variation[0.0], variation[50.0]
    assert spread_off > 0.005  # the unregularised actor does steer differently in different states
    assert spread_on < 0.25 * spread_off
    assert change_on < 0.5 * change_off


def test_smoothness_loss_is_zero_for_a_state_and_itself():
    """The temporal term compares mu(s) with mu(s'): a batch whose successors equal its states costs nothing; the
    spatial term is positive for a non-constant actor."""
    import types

    model, venv = _model(0.0, temporal_smoothness=1.0, spatial_smoothness=1.0, spatial_noise=1.0)
    obs = torch.as_tensor(model.get_vec_normalize_env().normalize_obs(_transitions(venv, 10)[0]))
    log = {"temporal_mse": [], "spatial_mse": []}
    model._smoothness_loss(types.SimpleNamespace(observations=obs, next_observations=obs.clone()), log)
    assert log["temporal_mse"] == [0.0] and log["spatial_mse"][0] > 0.0
    venv.close()


def test_actor_delay_trains_the_critics_alone_then_the_actor():
    """``actor_delay_steps``: the actor and the entropy coefficient are untouched while the critics learn, and
    both move once the delay has passed."""
    model, venv = _model(0.0, actor_delay_steps=400)
    actor0 = [p.detach().clone() for p in model.actor.parameters()]
    critic0 = [p.detach().clone() for p in model.critic.parameters()]
    alpha0 = float(model.log_ent_coef.detach())
    model.learn(total_timesteps=200)  # 50 vector steps, all inside the delay
    assert all(torch.equal(a, b) for a, b in zip(actor0, model.actor.parameters()))
    assert float(model.log_ent_coef.detach()) == alpha0
    assert any(not torch.equal(a, b) for a, b in zip(critic0, model.critic.parameters()))
    model.learn(total_timesteps=400, reset_num_timesteps=False)
    assert any(not torch.equal(a, b) for a, b in zip(actor0, model.actor.parameters()))
    assert float(model.log_ent_coef.detach()) != alpha0
    venv.close()


def test_bad_settings_are_refused():
    from vtrack_gym.agents.regularised_sac import RegularisedSAC

    for name in ("temporal_smoothness", "spatial_smoothness", "spatial_noise"):
        with pytest.raises(ValueError, match=f"{name} must be a finite number"):
            RegularisedSAC("MlpPolicy", "Pendulum-v1", **{name: -0.1})
    with pytest.raises(ValueError, match="spatial_noise must be a finite number > 0"):
        RegularisedSAC("MlpPolicy", "Pendulum-v1", spatial_noise=0.0)

    with pytest.raises(ValueError, match="bc_weight must be a finite number >= 0"):
        RegularisedSAC("MlpPolicy", "Pendulum-v1", bc_weight=-1.0)
    with pytest.raises(ValueError, match="bc_batch_size must be a positive int"):
        RegularisedSAC("MlpPolicy", "Pendulum-v1", bc_batch_size=0)
    with pytest.raises(ValueError, match="actor_delay_steps must be an int >= 0"):
        RegularisedSAC("MlpPolicy", "Pendulum-v1", actor_delay_steps=-1)
    model, venv = _model(1.0)
    dim = venv.observation_space.shape[0]
    bad = {"must be finite": (np.full((3, dim), np.nan), np.zeros(3)),
           rf"observations must have shape \(N >= 1, {dim}\)": (np.zeros((3, dim + 1)), np.zeros(3)),
           r"actions must have shape \(3, 1\)": (np.zeros((3, dim)), np.zeros(4)),
           r"lie in \[-1, 1\]": (np.zeros((3, dim)), np.full(3, 1.5))}
    for match, (obs, act) in bad.items():
        with pytest.raises(ValueError, match=match):
            model.set_demonstrations(obs, act)
    venv.close()


def test_bc_weight_needs_sac_and_a_warm_start(tmp_path):
    from vtrack_gym.agents.train import train

    with pytest.raises(ValueError, match="bc_weight applies to --algo sac with a --bc-expert warm start"):
        train("sac", timesteps=100, run_dir=tmp_path / "run", num_envs=2, overrides={"bc_weight": 1.0}, eval_freq=0,
              final_eval=False, progress_bar=False)
    assert not (tmp_path / "run").exists()  # refused before anything is written
    with pytest.raises(ValueError, match=r"\['temporal_smoothness'\] apply to --algo sac only"):
        train("ppo", timesteps=100, run_dir=tmp_path / "run", num_envs=2, overrides={"temporal_smoothness": 1.0},
              eval_freq=0, final_eval=False, progress_bar=False)
    assert not (tmp_path / "run").exists()


def test_a_refused_smoothness_value_writes_nothing(tmp_path):
    """An out-of-range value through train (the CLI's --set) is refused naming the field, before the run folder
    is made or an earlier run's config.json replaced."""
    from vtrack_gym.agents.train import train

    with pytest.raises(ValueError, match=r"temporal_smoothness must be a finite number >= 0 \(got -1\)"):
        train("sac", timesteps=100, run_dir=tmp_path / "new", num_envs=2, overrides={"temporal_smoothness": -1},
              eval_freq=0, final_eval=False, progress_bar=False)
    assert not (tmp_path / "new").exists()
    earlier = tmp_path / "earlier"
    earlier.mkdir()
    (earlier / "config.json").write_text("{\"earlier\": true}\n")
    with pytest.raises(ValueError, match="spatial_noise must be a finite number > 0"):
        train("sac", timesteps=100, run_dir=earlier, num_envs=2, overrides={"spatial_noise": 0.0}, eval_freq=0,
              final_eval=False, progress_bar=False)
    assert (earlier / "config.json").read_text() == "{\"earlier\": true}\n"

