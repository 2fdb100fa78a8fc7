"""GA tuning of the paper's controllers (issue 6): search spaces, batched population rollouts, presets.

``vtrack tune --controller smc --budget paper --space working --out smc_tuned.json``; see ``ga.tune``.
The Ray backend is not implemented (Ray is not a dependency); one process evaluates each generation as a
single batched rollout.
"""

from vtrack_gym.tuning.spaces import BUDGETS, SPACES, Budget, Parameter, SearchSpace, budget, search_space

__all__ = ["BUDGETS", "SPACES", "Budget", "Parameter", "SearchSpace", "budget", "search_space"]
