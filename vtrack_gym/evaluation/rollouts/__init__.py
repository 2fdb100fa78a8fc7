"""Policies driving envs: a rollout, a scored episode, the entry-speed search, where episodes run."""
