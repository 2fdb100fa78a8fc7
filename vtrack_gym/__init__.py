"""vtrack_gym: Gymnasium environments for driverless-car trajectory tracking.

``import vtrack_gym`` registers ``vtrack/LateralTracking-v0``, ``vtrack/DLC120-v0``, ``vtrack/LateralTrackingRandom-v0``
and ``vtrack/Track-v0`` (any track: ``track=``, ``speed_profile=``), the first three also without the namespace, and
loads nothing heavier than Gymnasium's registry (no numba, no torch). ``make_policy`` and ``evaluate`` import
what they need when called.
"""

from typing import Any as _Any

from vtrack_gym._version import __version__
from vtrack_gym.envs.registration import ALL_ENV_IDS, ENV_IDS, register_envs
from vtrack_gym.interop import register_highway_envs

__all__ = ["ALL_ENV_IDS", "ENV_IDS", "__version__", "evaluate", "leaderboard", "make_policy", "max_entry_speed_kmh",
           "register_envs"]


def make_policy(spec: str, env: _Any, preset: str | None = None, *, trust_code: bool = False,
                policy_kwargs: _Any = None) -> _Any:
    """The policy ``spec`` names, built for ``env``: a baseline (``"mpc"``), ``"name:preset"`` (``"smc:paper"``),
    a shipped agent (``"ppo"``, ``"sac"``), a weights-only agent file (``"agent.json"``) or, with
    ``trust_code=True``, ``"module:Name"`` of your code (``Name.from_env(env, **policy_kwargs)`` when the class
    defines it, else ``Name(**policy_kwargs)``).

    See ``vtrack_gym.baselines.resolve``; ``ValueError`` lists every valid name.
    """
    from vtrack_gym.baselines.resolve import resolve_policy

    return resolve_policy(spec, env, preset, trust_code=trust_code, policy_kwargs=policy_kwargs)


def evaluate(policy_or_factory: _Any, suite_or_env: _Any = "paper", seeds: _Any = None, **kwargs: _Any) -> list:
    """Score any object with ``predict`` (or a factory ``make(env)``) on a suite or env; one row per episode.

    Keywords: ``store`` (leaderboard file to add the rows to), ``vecnormalize`` (SB3 ``VecNormalize``
    statistics), ``policy_id``, ``workers`` (local processes), ``backend`` (``"local"`` or ``"ray"``). See
    ``vtrack_gym.evaluation.api.evaluate``.
    """
    from vtrack_gym.evaluation.api import evaluate as _evaluate

    return _evaluate(policy_or_factory, suite_or_env, seeds, **kwargs)


def leaderboard(source: _Any, suite: str | None = None, **kwargs: _Any) -> _Any:
    """The ranked board of ``suite`` from a store file or from result rows (e.g. ``evaluate``'s): a list of dicts
    with the columns and 95 % intervals of ``vtrack leaderboard --format json``, or a pandas DataFrame with
    ``as_frame=True``. Keywords: ``columns``, ``latest_only``, ``as_frame``. See
    ``vtrack_gym.evaluation.api.leaderboard``.
    """
    from vtrack_gym.evaluation.api import leaderboard as _leaderboard

    return _leaderboard(source, suite, **kwargs)


def max_entry_speed_kmh(policy: _Any, env_id: str = "vtrack/ISO3888-2-v1", **kwargs: _Any) -> _Any:
    """The highest entry speed [km/h] at which ``policy`` (a name such as ``"mpc"``, a factory ``make(env)`` or an
    object with ``predict``) passes an ISO 3888 lane change (``vtrack/ISO3888-1-v1``, ``vtrack/ISO3888-2-v1``), with
    the car's physical bound and the fraction of it. Keywords: ``vehicle``, ``lo_kmh``, ``hi_kmh``, ``tol_kmh``,
    ``checks``, ``seed``, ``policy_id``, ``on_probe``. See ``vtrack_gym.evaluation.rollouts.entry_speed``.
    """
    from vtrack_gym.evaluation.rollouts.entry_speed import max_entry_speed_kmh as _search

    return _search(policy, env_id, **kwargs)


register_envs()
register_highway_envs()  # the id only; highway-env loads on gym.make
