"""Figures and videos: the paper's plots, lap figures, each run's figure folder, policy videos."""
