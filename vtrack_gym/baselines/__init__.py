"""Scripted baseline policies (SMC, MPC, LQR, Stanley, pure pursuit, constrained MPC) and the PD-FLC speed loop."""
