"""Which episode an exception came from: the policy, the env and the seed, carried by the exception itself.

An error raised while an episode runs (a policy that raises in ``predict``, a factory that fails) keeps its own
type, so Python callers catch what they expect; ``in_episode`` records the episode on it (an attribute and a note
in its traceback). The record survives the pickling that brings a worker's exception back to the parent
(``worker_pool``), so the ``vtrack`` command can report any episode's failure in one line (``failure_line``),
with the traceback under ``-v``.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

EPISODE_ATTRIBUTE = "vtrack_episode"
"""The attribute ``in_episode`` sets on an exception: ``{"policy": ..., "env": ..., "seed": ...}``."""
MAX_MESSAGE_CHARS = 300
"""Longest cause text a failure line quotes (characters)."""


def mark_episode(exc: BaseException, policy_id: str, env_id: str, seed: Any) -> None:
    """Record on ``exc`` the episode it ended (the first record wins: the innermost episode)."""
    if getattr(exc, EPISODE_ATTRIBUTE, None) is not None:
        return
    with contextlib.suppress(AttributeError, TypeError):
        setattr(exc, EPISODE_ATTRIBUTE, {"policy": str(policy_id), "env": str(env_id), "seed": seed})
        exc.add_note(f"in the episode of {policy_id} on {env_id} seed {seed}")


@contextlib.contextmanager
def in_episode(policy_id: str, env_id: str, seed: Any) -> Iterator[None]:
    """Any ``Exception`` raised inside is marked with this episode (``mark_episode``) and raised on."""
    try:
        yield
    except Exception as exc:
        mark_episode(exc, policy_id, env_id, seed)
        raise


def episode_of(exc: BaseException) -> dict[str, Any] | None:
    """The episode ``exc`` ended (``mark_episode``), None when it was raised outside an episode."""
    found = getattr(exc, EPISODE_ATTRIBUTE, None)
    return found if isinstance(found, dict) else None


def failure_line(exc: BaseException) -> str | None:
    """``the episode of X on DLC120-v0 seed 2 failed: RuntimeError: ...`` for an exception raised in an episode
    (by the policy, its factory or the env), else None."""
    episode = episode_of(exc)
    if episode is None:
        return None
    cause = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    cause = " ".join(cause.split())
    if len(cause) > MAX_MESSAGE_CHARS:
        cause = cause[:MAX_MESSAGE_CHARS] + "..."
    return f"the episode of {episode['policy']} on {episode['env']} seed {episode['seed']} failed: {cause}"
