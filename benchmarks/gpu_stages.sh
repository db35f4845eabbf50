#!/usr/bin/env bash
# The GPU measurements of BENCHMARKS.md, in stages of at most 10 minutes each. Run from the repository root on the GPU machine, with jaxpg, JAX for CUDA and
# MuJoCo Warp installed (docs/gpus.md) or on PYTHONPATH with the checkout:
#
#   bash benchmarks/gpu_stages.sh card     # `python experiments/hopper.py --num-envs 256`, 3 seeds, cold and warm
#                                              # (SEEDS, MODES; EXTRA: flags added, e.g. "--preset hopper_1m")
#   bash benchmarks/gpu_stages.sh sweep    # NPG settings at 256 envs, 3 seeds vmapped, to 2 M env steps
#   bash benchmarks/gpu_stages.sh sweep8   # settings around the default, 8 seeds vmapped, to 1.97 M env steps
#   bash benchmarks/gpu_stages.sh ratio [FIELD=VALUE ...]  # train(+eval)/raw of the card's defaults
#                                              # (with these preset overrides) at 256-65536 envs
#   bash benchmarks/gpu_stages.sh sweep1m  # settings around the card's preset, 8 seeds vmapped, to 0.98 M env steps
#   bash benchmarks/gpu_stages.sh ablation # each phase's cost inside the compiled iteration, at 1024 and 4096 envs
#   bash benchmarks/gpu_stages.sh ablation_check  # throughput.py train and the ablation at 1024 envs on one machine
#                                              # (the two disagreed on the rollouts' time)
#   bash benchmarks/gpu_stages.sh order_check  # the ablation timed interleaved and grouped; the card's
#                                              # run, then one evaluation's cost per episodes, early stop or not;
#                                              # the README's GPU NPG command and its evaluations' share
#   bash benchmarks/gpu_stages.sh trace    # jax.profiler trace of the card's block; phases at 65536 envs
#   bash benchmarks/gpu_stages.sh ttr      # time to a Hopper return of 3000, NPG and PPO, 3 seeds each
#   bash benchmarks/gpu_stages.sh env      # raw env throughput table, then Pong figures
#   bash benchmarks/gpu_stages.sh suite_env  # the MuJoCo suite's raw and env throughput, 4096 and 16384 envs
#   bash benchmarks/gpu_stages.sh suite_fast "RUN ..."  # TASK:ppo:PRESET runs: seed 0 on a bare machine (empty
#                                              # caches), then seeds 0-2 (SEEDS) warm with its caches, one process
#                                              # per GPU (GPUS, default 0 1 2 3), Gymnasium scores; LIMIT seconds
#   bash benchmarks/gpu_stages.sh gym      # the README's GPU training commands, then Gymnasium evaluation
#   bash benchmarks/gpu_stages.sh scaling  # NPG over 1, 2, ... GPUs at a fixed batch per GPU
#   bash benchmarks/gpu_stages.sh extra S  # 2 GPUs: Pong A2C for S seconds on GPU 1 while GPU 0 tests
#                                              # whether XLA command buffers slow the fused scan of iterations
#   bash benchmarks/gpu_stages.sh atari    # Atari Pong: frames/s of each path, then PPO (Nature CNN, 16 games,
#                                              # 2500 iterations or 8 minutes) scored in ALE/Pong-v5
#   bash benchmarks/gpu_stages.sh atari_envs SECONDS N ...  # PPO on the ROM with N games, SECONDS each
#                                              # (needs ale-py: pip install -e ".[atari]")
#   bash benchmarks/gpu_stages.sh latency  # benchmarks/step_latency.py: a physics step per Warp graph mode and
#                                              # XLA command-buffer setting; latency_profile: its trace
#   CASE=npg bash benchmarks/gpu_stages.sh sweep_speed   # 64 configurations x 4 seeds as one sweep against
#                                              # sequential runs (CASE=ppo ITER=100 for the PPO case)
#   SUITE=jaxpg ENV=ant TRAINER=brax bash benchmarks/gpu_stages.sh brax_race  # one slice of the race
#                                              # (needs Brax's wheels: brax jaxopt ml_collections)
#
# Logs and JSON go to $OUT (default: benchmarks/results/latest). Every stage caps its parts with
# `timeout`, so that a slow part costs its own figures, not the whole call.
set -u
OUT=${OUT:-benchmarks/results/latest}
mkdir -p "$OUT"
export PYTHONUNBUFFERED=1 NCCL_NVLS_ENABLE=0
py=${PYTHON:-python3}
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader > "$OUT/gpu.txt" 2>&1

case "${1:-}" in
card)
  # SEEDS (default 0 1 2), MODES (default cold warm), EXTRA: flags added to the card's (e.g. --preset hopper_1m)
  timeout 570 $py benchmarks/card_command.py card --seeds ${SEEDS:-0 1 2} --modes ${MODES:-cold warm} --out /tmp/card \
    --json "$OUT/card.json" ${EXTRA:+--extra $EXTRA} 2>&1 | tee "$OUT/card.log" | grep -v "^WARN"
  ;;
sweep)
  timeout 570 $py benchmarks/time_to_return.py sweep --impl warp --settings base step07 step07vep10 s10vep10 \
    --seeds 0 1 2 --steps 2e6 --json "$OUT/sweep.json" 2>&1 | tee "$OUT/sweep.log" | grep -v "^WARN"
  ;;
sweep8)
  timeout 575 $py benchmarks/time_to_return.py sweep --impl warp \
    --settings step07vep10 vnorm std0 vnorm_std0 lam95 vnorm_s10 vep20 vnorm_vep5 \
    --seeds 0 1 2 3 4 5 6 7 --steps 1966080 --marks 1 1.5 1.966 --json "$OUT/sweep8.json" 2>&1 \
    | tee "$OUT/sweep8.log" | grep -v "^WARN"
  ;;
sweep1m)
  timeout 575 $py benchmarks/time_to_return.py sweep --impl warp --block 4 \
    --settings ${SETTINGS:-card card_s085 card_s10 card_h48 card_lam97 card_g995 card_vep15} \
    --seeds 0 1 2 3 4 5 6 7 --steps 983040 --marks 0.5 0.75 0.983 --json "$OUT/sweep1m.json" 2>&1 \
    | tee "$OUT/sweep1m.log" | grep -v "^WARN"
  ;;
ablation)
  timeout 575 $py benchmarks/iteration_ablation.py --num-envs ${SIZES:-1024 4096} --iterations 10 --rounds 5 \
    --json "$OUT/ablation.json" 2>&1 | tee "$OUT/ablation.log" | grep -v "^WARN"
  ;;
ablation_check)
  timeout 240 $py benchmarks/throughput.py train --impl warp --preset hopper --horizon 64 --iterations 10 \
    --repeats 5 --batch-sizes 1024 --json "$OUT/check_ratio.json" 2>&1 | tee "$OUT/check_ratio.log" | grep -v "^WARN\|^#"
  timeout 330 $py benchmarks/iteration_ablation.py --num-envs 1024 --iterations 10 --rounds 5 --changes unroll \
    --json "$OUT/check_ablation.json" 2>&1 | tee "$OUT/check_ablation.log" | grep -v "^WARN\|compiled in"
  ;;
order_check)
  timeout 300 $py benchmarks/iteration_ablation.py --num-envs 1024 --iterations 10 --rounds 5 --changes unroll \
    --order interleaved grouped --json "$OUT/order.json" 2>&1 | tee "$OUT/order.log" | grep -v "^WARN\|compiled in"
  timeout 150 $py experiments/hopper.py --num-envs 256 --run-dir /tmp/card0 --overwrite --no-progress \
    > "$OUT/card0.log" 2>&1; tail -4 "$OUT/card0.log"
  timeout 100 $py benchmarks/throughput.py eval /tmp/card0 --impl warp --episodes 16 64 --json "$OUT/eval_trained.json" \
    2>&1 | tee "$OUT/eval_trained.log" | grep "^|"
  timeout 60 $py benchmarks/throughput.py eval --impl warp --episodes 16 --json "$OUT/eval_fresh.json" \
    2>&1 | tee "$OUT/eval_fresh.log" | grep "^|"
  timeout 120 $py experiments/hopper.py --preset hopper_gpu --iterations 150 --run-dir /tmp/gpu --overwrite \
    --no-progress > "$OUT/hopper_gpu.log" 2>&1; grep -v "^WARN" "$OUT/hopper_gpu.log" | tail -5
  ;;
ratio)
  shift
  sets=(); [ $# -gt 0 ] && sets=(--set "$@")
  timeout 575 $py benchmarks/throughput.py train --impl warp --preset hopper --horizon 64 --iterations 5 \
    --batch-sizes ${SIZES:-256 1024 4096 16384 65536} "${sets[@]}" --json "$OUT/ratio.json" 2>&1 \
    | tee "$OUT/ratio.log" | grep -v "^WARN\|^#"
  ;;
trace)
  timeout 200 $py benchmarks/profile_trace.py --num-envs 256 --iterations 10 --out /tmp/trace 2>&1 \
    | tee "$OUT/trace.log" | grep -v "^WARN"
  timeout 300 $py experiments/hopper.py --num-envs 65536 --iterations 1 --profile --run-dir /tmp/prof65536 \
    --overwrite --no-progress 2>&1 | tee "$OUT/profile65536.log" | grep -A9 "^phase timings"
  ;;
ttr)
  common=(--block 10 --seeds 0 1 2 --warmup --max-seconds 150)
  timeout 330 $py benchmarks/time_to_return.py run --algo npg --preset hopper_gpu "${common[@]}" \
    --json "$OUT/ttr_npg.json" 2>&1 | tee "$OUT/ttr_npg.log" | grep -v "^  seed"
  timeout 240 $py benchmarks/time_to_return.py run --algo ppo --preset hopper_gpu "${common[@]}" \
    --json "$OUT/ttr_ppo.json" 2>&1 | tee "$OUT/ttr_ppo.log" | grep -v "^  seed"
  ;;
env)
  {
    timeout 150 $py benchmarks/throughput.py env --tasks hopper --fidelity fast --impl warp jax \
      --batch-sizes 4096 16384 65536 --variants raw env --horizon 100 --repeats 3 --json "$OUT/env_hopper.json"
    timeout 110 $py benchmarks/throughput.py env --tasks inverted_pendulum inverted_double_pendulum cartpole \
      --fidelity fast --impl warp jax --batch-sizes 4096 16384 --variants raw env --horizon 100 --repeats 3 \
      --json "$OUT/env_others.json"
    timeout 100 $py benchmarks/throughput.py env --tasks inverted_pendulum inverted_double_pendulum hopper \
      --fidelity gymnasium --impl warp jax --batch-sizes 4096 --variants env --horizon 100 --repeats 3 \
      --json "$OUT/env_gymnasium.json"
  } 2>&1 | tee "$OUT/env.log" | grep "^|"
  timeout 200 $py benchmarks/pong.py --fps-envs 1024 4096 --train-envs 1024 --seconds 120 \
    --json "$OUT/pong.json" 2>&1 | tee "$OUT/pong.log" | grep -v "^  a2c"
  ;;
gym)
  for algo in ppo npg; do
    timeout 200 $py experiments/hopper.py --algo $algo --preset hopper_gpu --iterations 150 \
      --run-dir "runs/hopper-$algo" --overwrite --video-every 0 --no-progress 2>&1 | tee "$OUT/cli_$algo.log" | tail -4
    for where in mjx gymnasium; do
      flag=$([ $where = gymnasium ] && echo --gymnasium)
      timeout 100 $py -m jaxpg.evaluate "runs/hopper-$algo" --episodes 10 --step best $flag 2>&1 \
        | tee "$OUT/eval_${algo}_$where.log" | tail -3
    done
  done
  ;;
scaling)
  timeout 420 $py benchmarks/throughput.py scaling --task hopper --envs-per-device 16384 --horizon 32 --iterations 5 \
    --json "$OUT/scaling.json" 2>&1 | tee "$OUT/scaling.log" | grep -E "^\||^#|rror"
  ;;
extra)
  seconds=${2:-240}
  CUDA_VISIBLE_DEVICES=1 timeout $((seconds + 60)) $py benchmarks/pong.py --fps-envs --train-envs 2048 \
    --seconds "$seconds" --json "$OUT/pong_long.json" > "$OUT/pong_long.log" 2>&1 &
  for flags in "" "--xla_gpu_enable_command_buffer="; do
    CUDA_VISIBLE_DEVICES=0 XLA_FLAGS="$flags" timeout 150 $py benchmarks/throughput.py train --task hopper \
      --impl warp --batch-sizes 4096 --horizon 32 --iterations 5 2>&1 | grep -E "^\| warp" | sed "s|^|XLA_FLAGS='$flags' |"
  done
  wait
  grep -A4 "^| A2C" "$OUT/pong_long.log"
  ;;
atari)
  timeout 200 $py benchmarks/pong.py atari-fps --envs 16 64 256 1024 --seconds 5 2>&1 | grep -v "A.L.E\|Stella" \
    | tee "$OUT/atari_fps.txt"
  rm -rf runs/atari-ppo
  timeout 480 $py experiments/atari_pong.py --run-dir runs/atari-ppo --checkpoint-every 100 --no-progress 2>&1 \
    | grep -v "A.L.E\|Stella" | tee "$OUT/atari-ppo.log" | tail -4
  for sticky in --sticky --no-sticky; do
    timeout 60 $py -m jaxpg.evaluate runs/atari-ppo --ale --episodes 10 $sticky 2>&1 | grep -v "A.L.E\|Stella" \
      | tee -a "$OUT/atari-ppo.eval.txt"
  done
  ;;
atari_envs)  # SECONDS N ...: PPO's Atari recipe with N games, one process and JSON per number of games
  seconds=$2
  shift 2
  for n in "$@"; do
    rm -rf runs/ppo-envs-$n
    timeout $((${seconds%.*} + 150)) $py benchmarks/pong.py --task atari_pong --algo ppo --compare-envs $n \
      --seconds $seconds --run-dir runs/ppo-envs-$n --json "$OUT/ppo-envs-$n.json" 2>&1 \
      | grep -v "A.L.E\|Stella" | tee "$OUT/ppo-envs-$n.log" | tail -4
  done
  ;;
suite_env)
  timeout 570 $py benchmarks/throughput.py env --tasks ${TASKS:-reacher humanoid_standup walker2d} --fidelity fast \
    --impl warp --batch-sizes 4096 16384 --variants raw env --horizon 200 --repeats 5 --json "$OUT/suite_env.json" \
    2>&1 | tee "$OUT/suite_env.log" | grep "^|"
  ;;
suite_fast)
  timeout ${LIMIT:-590} $py benchmarks/suite.py run --runs ${2:?TASK:ALGO:PRESET runs} --seeds ${SEEDS:-0 1 2} \
    --episodes 10 --bare-first --gpus ${GPUS:-0 1 2 3} --out /tmp/suite_fast --json "$OUT/suite_fast.json" 2>&1 \
    | tee "$OUT/suite_fast.log" | grep -v "^WARN"
  ;;
latency)
  # A physics step's latency per Warp graph mode and XLA command-buffer setting (BUDGET seconds), then a
  # jax.profiler trace of Hopper at 256 envs under MJX's default mode.
  timeout 560 $py benchmarks/step_latency.py --budget ${BUDGET:-400} --json "$OUT/step_latency.json" 2>&1 \
    | grep -v "^WARN" | tee "$OUT/step_latency.log"
  ;;
latency_profile)
  timeout 300 $py benchmarks/step_latency.py --tasks hopper --envs 256 --modes ${MODES:-WARP} --command-buffers default \
    --steps 10 --profile /tmp/trace --json "$OUT/profile.json" 2>&1 | grep -v "^WARN" | tee "$OUT/profile.log"
  ;;
sweep_speed)  # CASE npg|ppo; ITER: iterations of every run (default: the preset's); SEQ: sequential sample
  timeout ${LIMIT:-560} $py benchmarks/sweep_speed.py --case ${CASE:-npg} --sequential ${SEQ:-2} \
    ${ITER:+--iterations $ITER} --out /tmp/sweep_speed_${CASE:-npg} 2>&1 | grep -v "^WARN" \
    | tee "$OUT/sweep_speed_${CASE:-npg}.log"
  cp /tmp/sweep_speed_${CASE:-npg}/sweep_speed.json "$OUT/sweep_speed_${CASE:-npg}.json"
  ;;
brax_race)  # one slice per call: SUITE jaxpg|brax, ENV ant|humanoid, TRAINER jaxpg|brax, SEEDS, BUDGET seconds
  timeout ${LIMIT:-570} $py benchmarks/brax_race.py --suite ${SUITE:-jaxpg} --env ${ENV:-ant} \
    --trainer ${TRAINER:-brax} --seeds ${SEEDS:-0} --budget ${BUDGET:-300} \
    --json "$OUT/race-${SUITE:-jaxpg}-${ENV:-ant}-${TRAINER:-brax}.json" 2>&1 | grep -v "^WARN" \
    | tee "$OUT/race-${SUITE:-jaxpg}-${ENV:-ant}-${TRAINER:-brax}.log"
  ;;
*)
  echo "usage: bash benchmarks/gpu_stages.sh card|sweep|sweep8|sweep1m|ratio|ablation|ablation_check|order_check|trace|ttr|env|suite_env|suite_fast|gym|scaling|extra|atari|atari_envs|latency|latency_profile|sweep_speed|brax_race" >&2
  exit 2
  ;;
esac
