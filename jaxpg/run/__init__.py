"""The host side of a training run: flags, planning, the session, the run directory, checkpoints.

Everything here runs in Python between compiled calls; nothing under ``jaxpg.run`` is traced.
"""
