"""Time to a score: how long training takes to reach a return, and how settings change it.

Three modes (``python benchmarks/time_to_return.py MODE --help`` for each):

  run    wall-clock seconds for a policy to reach a target mean-policy return, compilation and
         evaluation included, one fresh process per seed;
  sweep  sample efficiency of named NPG settings on Hopper at the command line's batch (256
         envs), several seeds trained together, mean-policy returns at marks of env steps;
  plot   mean-policy return against wall clock from ``run --json`` files.

This script only dispatches: each mode lives in ``benchmarks/time_to_return_modes/``.

    python benchmarks/time_to_return.py run --task hopper --algo ppo --preset hopper_gpu --target 3000 \
        --seeds 0 1 2 --json ppo.json
    python benchmarks/time_to_return.py sweep --settings card card_s10 --seeds 0 1 2 3 4 5 6 7 --steps 1.97e6
    python benchmarks/time_to_return.py plot --out docs/hopper_time_to_return.png PPO=ppo.json NPG=npg.json
"""

from __future__ import annotations

import harness
from time_to_return_modes import plot, run, sweep

MODES = {"run": run.run_main, "sweep": sweep.sweep_main, "plot": plot.plot_main}


if __name__ == "__main__":
    harness.run_modes(__file__, MODES, __doc__)
