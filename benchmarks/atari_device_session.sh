#!/usr/bin/env bash
# The GPU measurements of Atari Pong on the ROM (BENCHMARKS.md, sections U, V, AD and AG), in stages
# that each fit one call of the device tool (10 minutes).
#
# The device machine reaches no package index: bring ale-py (and jaxtari, for `fps`) as wheels.
# On the development machine, from the repository root:
#   pip download --no-deps --only-binary=:all: --python-version 3.12 ale-py==0.12.1 jaxtari==0.2.0 -d wheels
#   echo /wheels/ >> .git/info/exclude          # ignored, so the device tool can carry it
# and run each stage with carry ["wheels"]. Then, on the device machine, from the repository root:
#
#   bash benchmarks/atari_device_session.sh fps       # frames/s of every path at 16-1024 envs
#   bash benchmarks/atari_device_session.sh a2c       # A2C, 64 envs, 9 minutes of training, then ALE/Pong-v5
#   bash benchmarks/atari_device_session.sh a2c 256   # the same with 256 envs
#   bash benchmarks/atari_device_session.sh reinforce # reinforce_points, 64 envs, 9 minutes, then ALE/Pong-v5
#   bash benchmarks/atari_device_session.sh reinforce 32 460 --conv-torso nature ...   # with more flags
#   bash benchmarks/atari_device_session.sh ppo [SECONDS]      # PPO with the Nature CNN (preset), 16 envs
#   bash benchmarks/atari_device_session.sh a2c_cnn [SECONDS [ENVS [flags]]]  # A2C, Nature CNN (--preset atari)
#   bash benchmarks/atari_device_session.sh envs      # MinPy's comparison on the ROM: 1 2 4 16 64 envs, 100 s each
#   bash benchmarks/atari_device_session.sh ppo_envs SECONDS N ...  # the comparison with PPO (Nature CNN), SECONDS each
#   bash benchmarks/atari_device_session.sh long [MINUTES [RUN ...]]  # A2C (a2c: --preset atari, 16 games) and
#                                              # REINFORCE (reinforce_points: 32 games, Nature CNN), both unless RUNs
#                                              # are named, in the background (setsid), MINUTES of training each, then ALE/Pong-v5
#   bash benchmarks/atari_device_session.sh long_wait [SECONDS]  # wait for `long` (at most SECONDS), copy its results to $OUT:
#                                              # per run its log with the evaluations, metrics.jsonl.gz, and its run
#                                              # directory with the last checkpoint as run-NAME.tgz.NN (15 MB parts)
#   bash benchmarks/atari_device_session.sh resume_fg MINUTES [eval]  # continue the A2C run (from .atari-runs, or
#                                              # left on the machine by the previous call) for MINUTES in the
#                                              # foreground, optionally evaluate it, and bring it back as long_wait does
#   To continue those runs in a later call: put the run-*.tgz.* files in .atari-runs/ (git-ignored:
#   echo /.atari-runs/ >> .git/info/exclude), carry it, and `long` resumes each run it finds there
#   (python -m jaxpg.cli --resume) for MINUTES more instead of starting afresh.
#
# Runs go to runs/atari-*; logs to $OUT (default: benchmarks/results/latest). A training stage
# stops after its time (`timeout`): its latest checkpoint (every 250 iterations) is evaluated, and
# metrics.jsonl gives the env steps and wall-clock seconds of every iteration.
set -u
OUT=${OUT:-benchmarks/results/latest}
mkdir -p "$OUT"
export PYTHONUNBUFFERED=1
py=${PYTHON:-python3}
if ! $py -c "import ale_py" 2>/dev/null; then
  $py -m pip install -q --no-index --no-deps wheels/ale_py-*.whl || { echo "error: no ale-py (see the top of $0)"; exit 2; }
fi
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader > "$OUT/gpu.txt" 2>&1
nproc > "$OUT/cores.txt"

train_and_evaluate() {  # algo num_envs seconds [more flags of experiments/atari_pong.py]
  local algo=$1 envs=$2 seconds=$3
  shift 3
  local run=runs/atari-$algo-$envs
  rm -rf "$run"
  timeout "$seconds" $py experiments/atari_pong.py --algo "$algo" --num-envs "$envs" --iterations 1000000 \
    --log-every 50 --checkpoint-every 250 --run-dir "$run" --no-progress "$@" 2>&1 | tee "$OUT/atari-$algo-$envs.log" \
    | grep -v "A.L.E\|Stella"

  cp "$run/metrics.jsonl" "$OUT/atari-$algo-$envs.metrics.jsonl"
  for sticky in --sticky --no-sticky; do
    timeout 60 $py -m jaxpg.evaluate "$run" --ale --episodes 10 $sticky 2>&1 | grep -v "A.L.E\|Stella" \
      | tee -a "$OUT/atari-$algo-$envs.eval.txt"
  done
}

bring_back() {  # RUN_DIR LABEL: to $OUT, LABEL.metrics.jsonl.gz and the run directory with its last checkpoint
  # as run-NAME.tgz.NN (15 MB parts), which .atari-runs/ takes back for `long` or `resume_fg`
  local run=${1%/} name last
  name=$(basename "$run") last=$(ls "$run/checkpoints" | sort -n | tail -n 1)
  gzip -c "$run/metrics.jsonl" >"$OUT/$2.metrics.jsonl.gz"
  tar czf - -C "$(dirname "$run")" "$name/config.json" "$name/metrics.jsonl" "$name/checkpoints/$last" \
    | split -b 15000000 -d - "$OUT/run-$name.tgz."
}

case "${1:-}" in
fps)
  $py -m pip install -q --no-index --no-deps wheels/jaxtari-*.whl 2>/dev/null
  timeout 570 $py benchmarks/atari_throughput.py --envs 16 64 256 1024 --seconds 5 2>&1 | grep -v "A.L.E\|Stella" \
    | tee "$OUT/atari_throughput.txt"
  ;;
a2c)
  train_and_evaluate a2c "${2:-64}" 540
  ;;
reinforce)  # [ENVS [SECONDS [more flags]]]
  train_and_evaluate reinforce_points "${2:-64}" "${3:-540}" "${@:4}"
  ;;
ppo)  # the preset's 2500 iterations, or the time limit
  train_and_evaluate ppo 16 "${2:-460}" --iterations 2500 --checkpoint-every 100
  ;;
a2c_cnn)  # [SECONDS [ENVS [more flags]]]
  train_and_evaluate a2c "${3:-16}" "${2:-460}" --preset atari --checkpoint-every 2000 --log-every 500 "${@:4}"
  ;;
envs)
  rm -rf runs/atari-envs
  timeout 590 $py benchmarks/pong.py --task atari_pong --compare-envs 1 2 4 16 64 --seconds 96 \
    --run-dir runs/atari-envs --json "$OUT/atari-envs.json" 2>&1 | grep -v "A.L.E\|Stella" | tee "$OUT/atari-envs.log"
  cp runs/atari-envs/pong_envs.png "$OUT/" 2>/dev/null
  ;;
ppo_envs)  # SECONDS N ...: the same comparison with PPO's Atari recipe, one process and JSON per number of games
  seconds=$2
  shift 2
  for n in "$@"; do
    rm -rf runs/ppo-envs-$n
    timeout $((${seconds%.*} + 150)) $py benchmarks/pong.py --task atari_pong --algo ppo --compare-envs $n \
      --seconds $seconds --run-dir runs/ppo-envs-$n --json "$OUT/ppo-envs-$n.json" 2>&1 \
      | grep -v "A.L.E\|Stella" | tee "$OUT/ppo-envs-$n.log" | tail -4
  done
  ;;
long)  # [MINUTES [RUN ...]]: runs (a2c, reinforce_points; default both) in the background, so that they outlive this call
  minutes=${2:-21}
  runs=${*:3}
  runs=${runs:-a2c reinforce_points}
  mkdir -p /tmp/atari-long/src
  # The runs import from their own copy of the sources: a later call of the device tool replaces
  # the working tree, and each run's final evaluation starts a new process.
  cp -r jaxpg experiments benchmarks pyproject.toml /tmp/atari-long/src/
  for name in $(ls .atari-runs 2>/dev/null | sed -n 's/^run-\(.*\)\.tgz\.00$/\1/p'); do
    cat .atari-runs/run-"$name".tgz.* | tar xzf - -C /tmp/atari-long && echo "resuming $name"
  done
  export PYTHONPATH=/tmp/atari-long/src${PYTHONPATH:+:$PYTHONPATH}
  [ "$(echo $runs | wc -w)" -gt 1 ] && export XLA_PYTHON_CLIENT_MEM_FRACTION=0.4  # two JAX processes share the GPU
  for algo in a2c reinforce_points; do
    case " $runs " in *" $algo "*) ;; *) touch "/tmp/atari-long/$algo.done"; continue ;; esac
    if [ "$algo" = a2c ]; then
      flags="a2c 16 $minutes --preset atari --checkpoint-every 2000 --log-every 500"
      prio=""
    else
      flags="reinforce_points 32 $minutes --conv-torso nature --policy-hidden 512 --network-init orthogonal --lr 3e-4 --checkpoint-every 250 --log-every 50"
      prio="nice -n 19"
    fi
    # Started directly (not from a subshell that would keep this call's output open until the run ends).
    setsid nohup $prio env -C /tmp/atari-long/src bash benchmarks/atari_device_session.sh _long_one $flags \
      >/tmp/atari-long/$algo.out 2>&1 </dev/null &
  done
  sleep 120
  tail -n 3 /tmp/atari-long/*.log
  ;;
_long_one)  # ALGO ENVS MINUTES [flags]: one run of `long`, then its evaluation on ALE/Pong-v5
  algo=$2 envs=$3 minutes=$4
  shift 4
  run=/tmp/atari-long/$algo-$envs
  if [ -e "$run/config.json" ]; then  # unpacked from .atari-runs by `long`: continue it
    $py -m jaxpg.cli --resume "$run" --minutes "$minutes" --no-progress >"/tmp/atari-long/$algo.log" 2>&1
  else
    $py experiments/atari_pong.py --algo "$algo" --num-envs "$envs" --iterations 100000000 --minutes "$minutes" \
      --run-dir "$run" --overwrite --no-progress "$@" >"/tmp/atari-long/$algo.log" 2>&1
  fi
  for sticky in --sticky --no-sticky; do
    timeout 300 $py -m jaxpg.evaluate "$run" --ale --episodes 10 $sticky 2>&1 | grep -v "A.L.E\|Stella" \
      >>"/tmp/atari-long/$algo.eval.txt"
  done
  touch "/tmp/atari-long/$algo.done"
  ;;
resume_fg)  # MINUTES [eval]: continue the A2C run (a2c-16) in the foreground of this call, then bring it back
  # like long_wait. The run comes from .atari-runs on the first call on a machine and from
  # /tmp/atari-long on the next ones (the machine keeps it while calls follow each other).
  minutes=$2 run=/tmp/atari-long/a2c-16
  mkdir -p /tmp/atari-long
  if [ ! -e "$run/config.json" ]; then
    cat .atari-runs/run-a2c-16.tgz.* | tar xzf - -C /tmp/atari-long || { echo "error: no run in .atari-runs"; exit 2; }
  fi
  $py -m jaxpg.cli --resume "$run" --minutes "$minutes" --no-progress 2>&1 | grep -v "A.L.E\|Stella" \
    >>/tmp/atari-long/a2c.log
  if [ "${3:-}" = eval ]; then
    for sticky in --sticky --no-sticky; do
      timeout 240 $py -m jaxpg.evaluate "$run" --ale --episodes 10 $sticky 2>&1 | grep -v "A.L.E\|Stella" \
        >>/tmp/atari-long/a2c.eval.txt
    done
  fi
  { tail -n 40 /tmp/atari-long/a2c.log; cat /tmp/atari-long/a2c.eval.txt 2>/dev/null; } >"$OUT/resume-a2c.log"
  tail -n 12 "$OUT/resume-a2c.log"
  bring_back "$run" resume-a2c
  ls "$OUT"
  ;;
long_wait)  # [SECONDS]
  end=$((SECONDS + ${2:-570}))
  while [ $SECONDS -lt $end ] && ! { [ -e /tmp/atari-long/a2c.done ] && [ -e /tmp/atari-long/reinforce_points.done ]; }; do
    sleep 10
  done
  # At most 8 files come back from a call: per run its log (evaluations appended), its metrics, and
  # its run directory with the last checkpoint, in 15 MB parts.
  for algo in a2c reinforce_points; do
    {
      cat "$OUT/gpu.txt" "$OUT/cores.txt"
      grep -v "A.L.E\|Stella" "/tmp/atari-long/$algo.log" | tail -n 40
      cat "/tmp/atari-long/$algo.eval.txt" 2>/dev/null
    } >"$OUT/long-$algo.log"
    echo "== $algo"; tail -n 10 "$OUT/long-$algo.log"
    run=$(ls -d /tmp/atari-long/$algo-*/ 2>/dev/null | head -n 1)
    [ -n "$run" ] || continue
    bring_back "$run" "long-$algo"
  done
  rm -f "$OUT/gpu.txt" "$OUT/cores.txt"
  ls "$OUT"
  ;;
*)
  echo "usage: bash $0 fps|a2c [ENVS]|reinforce [ENVS]|ppo [SECONDS]|a2c_cnn [SECONDS]|envs|long [MINUTES]|long_wait [SECONDS]"
  exit 2
  ;;
esac
