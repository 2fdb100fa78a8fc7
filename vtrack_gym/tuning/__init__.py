"""GA tuning of controller parameters: search spaces, batched population rollouts, presets.

``vtrack tune --controller smc --budget paper --space working --out smc_tuned.json`` calls ``job.tune_to_preset``
(GA run, preset file with provenance, optional store row); the GA itself is ``ga.tune``. The GA works on any
controller that declares the tuning protocol (``vtrack_gym.baselines.tunable``: its spaces, budgets and batched
law); it never dispatches on a controller's name or type.
Each generation is evaluated as one batched rollout in this process (``--backend local``) or split row-wise over
the workers of a Ray cluster (``--backend ray``, optional dependency ``vtrack_gym[ray]``; see ``backends``), with a
bit-identical result.
"""

from vtrack_gym.tuning.spaces import Budget, Parameter, SearchSpace, budget, search_space

__all__ = ["Budget", "Parameter", "SearchSpace", "budget", "search_space"]
