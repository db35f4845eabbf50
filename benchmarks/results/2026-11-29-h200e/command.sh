# One H200 (16 host cores), 2026-11-29, JAX 0.11.2, MuJoCo/MJX 3.17.0, warp-lang 1.18.0, MuJoCo Warp;
# the code at 8981cce (the falling ceiling; 85a4824 added the floor as --log-std-min). Three calls, each on a freshly started machine (the scripts ran detached, polled).

# hopper_1m_log_std/ls0-*, ls-1-*: a ceiling on the log-std falling from 1 (the preset's initial log-std)
# to F = 0 or -1 over the 120 iterations, seeds 3000-3095 in three vmapped blocks of 32, the three
# processes of one setting on the GPU at once (190-221 s each, Gymnasium replays included).
for F in 0 -1; do
  for first in 3000 3032 3064; do
    python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $(seq $first $((first + 31))) --vmap-seeds \
      --out runs/ls$F-$first --json hopper_1m_log_std/ls$F-seeds$first.json \
      --extra --log-std-final $F --anneal-log-std-iterations 120 &
  done; wait
done

# hopper_1m_log_std/fl0.75-*, fl1.0-*, fl1.25-*: the log-std held at or above a floor FL, under a constant
# ceiling (FL 0.75 and 1.0: ceiling 1; FL 1.25: initial log-std and ceiling 1.25). These ran before the
# product had --log-std-min: a scratch copy of jaxpg/algos/core/log_std_bounds.py clipped with
# jnp.maximum(jnp.minimum(log_std, ceiling), FL), FL read from an environment variable, which is the
# clip that --log-std-min FL applies since, in the same order. So the JSON files' flags lack it; the
# equivalent commands:
for FL in 1.0 0.75; do            # seeds 3000-3095, the three blocks of one setting at once
  for first in 3000 3032 3064; do
    python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $(seq $first $((first + 31))) --vmap-seeds \
      --out runs/fl$FL-$first --json hopper_1m_log_std/fl$FL-seeds$first.json \
      --extra --log-std-min $FL --log-std-final 1.0 --anneal-log-std-iterations 120 &
  done; wait
done
# then four blocks at once (266-285 s each): FL 1.0 on seeds 3096-3159, FL 1.25 on seeds 3000-3063.
for first in 3096 3128; do
  python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $(seq $first $((first + 31))) --vmap-seeds \
    --out runs/fl1.0-$first --json hopper_1m_log_std/fl1.0-seeds$first.json \
    --extra --log-std-min 1.0 --log-std-final 1.0 --anneal-log-std-iterations 120 &
done
for first in 3000 3032; do
  python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $(seq $first $((first + 31))) --vmap-seeds \
    --out runs/fl1.25-$first --json hopper_1m_log_std/fl1.25-seeds$first.json \
    --extra --log-std-init 1.25 --log-std-min 1.25 --log-std-final 1.25 --anneal-log-std-iterations 120 &
done; wait

# The counts: python benchmarks/suite.py count hopper_1m_log_std/fl1.0-seeds*.json --bar 3000 (one setting's
# files at a time: the floor runs' recorded flags do not tell FL 0.75 from 1.0).
