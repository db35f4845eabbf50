#!/bin/bash
# The host's work between the card command's blocks, callback by callback (hostwork.py wraps each of
# jaxpg.run.callbacks.host_callbacks' callables and Checkpoints.plot in a timer and prints the totals at
# exit), on this machine's 2 CPU cores with MJX's JAX implementation and 16 envs (the host work does not
# depend on the env count: the same 12 blocks, 2 checkpoints, the same curves), 2026-12-05. Alternating,
# three runs each: curves.png first drawn at the first checkpoint (iteration 60; FIRST_PLOT_AT_ONCE=1, the
# behaviour before) against first drawn PLOT_EVERY_S = 30 s after the start (so only at the end here):
for i in 1 2 3; do
  rm -rf /tmp/hw/r
  FIRST_PLOT_AT_ONCE=1 python benchmarks/results/2026-12-05-cpu-host-work/hostwork.py --num-envs 16 --impl jax \
    --run-dir /tmp/hw/r > old$i.log 2>&1
  rm -rf /tmp/hw/r
  python benchmarks/results/2026-12-05-cpu-host-work/hostwork.py --num-envs 16 --impl jax --run-dir /tmp/hw/r > new$i.log 2>&1
done
# Drawing curves.png, in all: 1.027, 0.803, 0.974 s (0.64-0.84 s at iteration 60, with matplotlib's import,
# and 0.16-0.27 s at 120) against 0.681, 0.683, 0.664 s (one drawing, at 120). The Checkpoints callback
# (saves and drawings): 1.300, 1.045, 1.240 s against 1.026, 0.958, 0.926 s. The run's own "host work
# between blocks" line: 1.4, 1.1, 1.3 s against 1.1, 1.0 and under 1.0 s (not printed). Every other
# callback: under 0.05 s a run in all.

# The one-off Python this ran (hostwork.py ) left the tree when results/ became records and commands only;
# it is at commit 20ac6f2: git show 20ac6f2:benchmarks/results/2026-12-05-cpu-host-work/NAME.py
