"""Who drove where: a policy's fingerprint and display name, an env set-up's identity and spelling."""
