#!/bin/bash
# One H100 (80GB HBM3, 16 cores), 2026-12-05 12:14-12:40 UTC, two freshly started machines, JAX 0.11.2,
# MuJoCo/MJX 3.17.0, warp-lang 1.18.0, at commit b4c54fd. Installed as in the GPU recipe (warp-lang
# carried in four parts and reassembled, sha256 090962bf...; MuJoCo, MJX, Gymnasium as wheels) into
# /tmp/site, with --no-compile; card.sh compiles them to bytecode itself, as a user's pip install would.
#
# First machine (12:14-12:33):
#   setsid nohup bash benchmarks/results/2026-12-05-h100/both.sh > /tmp/both.log 2>&1 < /dev/null &
#   bash benchmarks/results/2026-12-05-h100/poll.sh 560 /tmp/outc
# both.sh ran card.sh's short form into card/ (card_a: bare seed 0 then warm seed 0; card_b, card_c: warm
# seeds 1, 2; card_noautotune: bare seed 3 with XLA_FLAGS=--xla_gpu_autotune_level=0), then suite_1m.sh
# into suite_1m/ (HalfCheetah's 1 M PPO preset with both levers, 32 seeds; Reacher's TRPO at 512 x 64
# with value minibatches of 1024 (r64k) and of 128 (r128), 4 seeds each; each replayed in Gymnasium).
# Then, on the same machine, from the same repository copy (/tmp/repo-card):
D=/tmp/outd
python3 benchmarks/card_command.py card --out $D/card --seeds 1 2 --modes cold --json $D/card_d.json
XLA_FLAGS=--xla_gpu_autotune_level=0 python3 benchmarks/card_command.py card --out $D/noautotune --seeds 4 5 \
  --modes cold --json $D/card_noautotune2.json
D=/tmp/outc  # the warm caches card_a filled
python3 benchmarks/card_command.py card --out $D/card --seeds 3 4 5 6 7 --modes warm --json $D/card_e.json
for s in 8 9 10; do  # one seed a process: no Gymnasium replay runs beside a timed run
  python3 benchmarks/card_command.py card --out $D/card --seeds $s --modes warm --json $D/card_f$s.json
done
# card_e's runs 4-7 each ran beside the previous seed's Gymnasium replay (card_command.py replays while
# the next run trains), as card_a's warm run did beside the bare run's replay: their times are not the
# quiet warm figure. card_b, card_c and card_f* ran alone.
#
# Second machine (12:36-12:40), bare: Reacher's TRPO at 512 envs x 64 steps, value minibatches of 1024
# (now `--algo trpo --preset reacher_fast`), one seed a process, seed 0 first with nothing cached:
python3 benchmarks/suite.py run --runs reacher:trpo:reacher_1m --seeds 0 1 2 --episodes 10 --out /tmp/rf \
  --json reacher_fast/reacher_fast.json --extra --num-envs 512 --horizon 64 --value-batch-size 1024
# run_files/ hold each run's config.json and metrics.jsonl (gzipped); HalfCheetah's metrics (over 3 MB)
# did not come back.
