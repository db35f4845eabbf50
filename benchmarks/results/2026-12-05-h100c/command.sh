#!/bin/bash
# Two H100 machines in one session, 2026-12-05 (JAX 0.11.2, MuJoCo/MJX 3.17.0, warp-lang 1.18.0, installed
# as in the GPU recipe with --no-compile, then compiled to bytecode as pip would; hosts' CPUs "Intel(R)
# Xeon(R) Processor", 16 cores). "now" is the package code at 1ef06d5 (curves.png drawn by a helper
# process, scipy.spatial deferred while MJX is imported); "before" is 9dd5a49's jaxpg/, carried beside it.
#
# Host 1 (16:04-16:17 UTC): lease.sh, steps 1-3. The machine was released while idle before its files
# were packed; host1.md transcribes what the calls printed. Step 4 and the A2C part were lost.
#
# Host 2 (16:19-16:31 UTC, a freshly started machine; files in host2/): the same card runs, new code only,
# then the before/now A/B. As run (the repository copy in /tmp/repo-new, "before" in /tmp/repo-old):
D=/tmp/outd
C="python3 benchmarks/card_command.py card --out $D/card"
$C --seeds 0 --modes cold --json $D/card_bare0.json                 # the machine's first run: bare
cp -r $D/card/caches-cold-0 $D/card/caches-warm
for s in 1 2 3; do $C --seeds $s --modes warm --json $D/new_warm$s.json; done
$C --seeds 4 5 --modes cold --json $D/card_bare45.json              # bare: each run empties its caches
for s in 6 7 8; do $C --seeds $s --modes warm --json $D/new_warm$s.json; done
mkdir -p $D/card_old && cp -r $D/card/caches-warm $D/card_old/caches-warm
for s in 11 12 13; do                                                  # alternating, the same caches
  (cd /tmp/repo-old && python3 benchmarks/card_command.py card --out $D/card_old --seeds $s --modes warm \
     --json $D/old_warm$s.json)
  $C --seeds $s --modes warm --json $D/new_warm$s.json
done
# host2/card_logs/warm-seed1{1,2,3}.log are the "before" runs' logs (copied last, over the new ones');
# new_warm1?.log and the JSON rows are each run's own.
#
# Then, on host 2, Swimmer's fast preset as typed, cut off after 400 s by the lease's end
# (swimmer_fast_partial/): seed 0 bare, then seeds 0 and 1 warm; seed 2 and the warm runs' Gymnasium
# replays did not run.
timeout 400 python3 benchmarks/suite.py run --runs swimmer:trpo:swimmer_fast --seeds 0 1 2 --bare-first \
  --episodes 10 --out /tmp/out_sw/runs --json /tmp/out_sw/swimmer_fast.json
