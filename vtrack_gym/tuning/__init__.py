"""GA tuning of the paper's controllers (issue 6): search spaces, batched population rollouts, presets.

``vtrack tune --controller smc --budget paper --space working --out smc_tuned.json`` calls ``job.tune_to_preset``
(GA run, preset file with provenance, optional store row); the GA itself is ``ga.tune``.
Each generation is evaluated as one batched rollout in this process (``--backend local``) or split row-wise over
the workers of a Ray cluster (``--backend ray``, optional dependency ``vtrack_gym[ray]``; see ``backends``), with a
bit-identical result.
"""

from vtrack_gym.tuning.spaces import BUDGETS, SPACES, Budget, Parameter, SearchSpace, budget, search_space

__all__ = ["BUDGETS", "SPACES", "Budget", "Parameter", "SearchSpace", "budget", "search_space"]
