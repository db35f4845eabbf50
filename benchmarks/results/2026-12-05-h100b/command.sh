#!/bin/bash
# One H100 (80GB HBM3; 16 cores, "Intel(R) Xeon(R) Processor"), 2026-12-05 14:32-14:53 UTC, one freshly
# started machine, JAX 0.11.2, MuJoCo/MJX 3.17.0, warp-lang 1.18.0. The package code at 4ebe23f (788a992
# adds only scripts). Installed as in the GPU recipe (warp-lang carried in five parts and reassembled,
# sha256 090962bf...; MuJoCo, MJX, Gymnasium as wheels) into /tmp/site with --no-compile; lease.sh then
# compiles them to bytecode, as a user's pip install would.
#
#   setsid nohup bash benchmarks/results/2026-12-05-h100b/lease.sh > /tmp/lease.log 2>&1 < /dev/null &
#
# lease.sh's step 1 (card/: bare seed 0, then warm seeds 1-3, each alone in its own process) ran as
# written. Step 2, the six 1 M presets side by side (suite_h100.sh PART=1m), was stopped after 10
# minutes: sharing the GPU six ways, Pusher had reached 0.27 M env steps, Reacher 0.29 M and Swimmer
# 0.16 M; HalfCheetah, Ant and Humanoid had written no metrics yet, and Humanoid's process had exited
# (its log was empty; cause not known). Their configs and metrics are in suite_1m_stopped/. The rest
# of lease.sh was run by hand on the same machine, from the same repository copy (/tmp/repo-next):
D=/tmp/out
python3 benchmarks/suite.py run --runs reacher:trpo:reacher_fast --seeds 0 1 2 --bare-first --episodes 10 \
  --out $D/runs --json $D/reacher_fast.json          # reacher_fast/, run_files/ gzipped
python3 benchmarks/card_command.py card --out $D/card --seeds 4 5 --modes cold --json $D/card_bare45.json
for s in 6 7 8; do  # one seed a process, with the warm caches of step 1
  python3 benchmarks/card_command.py card --out $D/card --seeds $s --modes warm --json $D/card_warm$s.json
done
python3 benchmarks/card_command.py startup --repeats 3 --json $D/startup.json    # startup.json, .log
