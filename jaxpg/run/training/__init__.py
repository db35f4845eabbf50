"""A training run on the host: the session and its callbacks between compiled blocks, and the
check that stops a diverged run."""
