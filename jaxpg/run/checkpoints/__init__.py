"""Checkpoints: Orbax saves of the whole train state, their format and checks, and loading a policy."""
