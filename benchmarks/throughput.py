"""Throughput: how many env steps per second the simulation, training and its pieces run at.

One script, six modes (``python benchmarks/throughput.py MODE --help`` for each):

  env       raw environment throughput, random actions, no policy: the physics alone, the bare
            task and the env a sampler steps (wrappers and automatic reset);
  train     training throughput against raw simulation of the same batch, per implementation and
            batch size (each in a fresh process), optionally with a preset's evaluation charged;
  scaling   NPG training over 1, 2, 4, ... devices at a fixed batch per device;
  learner   GAE and the value fit in several equivalent forms, timed alone;
  eval      what one mean-policy evaluation costs, with and without its early stop;
  host      the host's work after each block of a many-seed run (metrics, curves, a checkpoint).

Every figure is timed with ``benchmarks/harness.py`` (synchronised calls, median of repeats) and
every mode prints a Markdown table; ``--json`` writes the rows. This script only dispatches: each mode
lives in ``benchmarks/throughput_modes/``. Lettered sections cited in the modes' docs are those of the
benchmark record, ``docs/benchmarks_archive.md``.
"""

from __future__ import annotations

import harness
from throughput_modes import env, evaluation, host, learner, scaling, train

MODES = {
    "env": env.env_main,
    "train": train.train_main,
    "scaling": scaling.scaling_main,
    "learner": learner.learner_main,
    "eval": evaluation.eval_main,
    "host": host.host_main,
}


if __name__ == "__main__":
    harness.run_modes(__file__, MODES, __doc__)
