"""The Gymnasium MuJoCo suite trained: tasks x presets x seeds, each a fresh process as a user runs
it, each final mean policy scored in Gymnasium's own v5 env, against the published figures.

Four modes (``python benchmarks/suite.py MODE --help`` for each):

  run   train every ``TASK:ALGO:PRESET`` for every seed, then replay each run's final mean policy
        in Gymnasium; print the table, write JSON (runs and their metrics);
  plot  mean-policy return against wall clock and against env steps, one panel per task, the
        seeds of each preset as a band, from ``run --json`` files;
  count how many seeds of each setting reached a score, over any number of ``run --json`` files
        (to judge a setting's failure rate over hundreds of seeds);
  physics replay each seed's policy of a run directory in Gymnasium's env under Gymnasium's
        physics and under jaxpg's fast fidelity: does a policy lose return to the physics change?

This script only dispatches: each mode lives in ``benchmarks/suite_modes/``.

    python benchmarks/suite.py run --runs walker2d:npg:walker2d_1m half_cheetah:npg:half_cheetah_1m --seeds 0 1 2 \\
        --json suite.json
    python benchmarks/suite.py plot suite.json --out docs/suite.png
    python benchmarks/suite.py physics RUN_DIR --episodes 20 --json physics.json
"""

from __future__ import annotations

import sys

import harness
from suite_modes import count, physics, plot, run, verdicts

MODES = {"run": run.run_main, "plot": plot.plot_main, "count": count.count_main, "physics": physics.physics_main}
__all__ = ["MODES", "verdicts"]  # verdicts: the targets a setting is judged against


if __name__ == "__main__":
    if sys.argv[1:] in (["-h"], ["--help"]):  # asked for: the modes, exit status 0
        print(__doc__)
        raise SystemExit(0)
    harness.run_modes(__file__, MODES, __doc__)
