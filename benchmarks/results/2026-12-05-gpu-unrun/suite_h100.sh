#!/bin/bash
# The suite's rows with no H100 figure yet, in parts that each fit one lease (30 minutes of device time,
# about 25 after the machine's start and the wheels' staging). PART=a2c, swimmer_fast and rest have run
# (../2026-12-05-h100d/, ../2026-12-05-h100e/), and hopper_fast and ant_anneal (../2026-12-05-h100f/); hopper_gpu
# has not.
# Six programs side by side do not fit a lease: on 2026-12-05 (benchmarks/results/2026-12-05-h100b/),
# sharing one H100 six ways, Pusher, Reacher and Swimmer reached only 0.16-0.29 M env steps in 10 minutes.
# Ant's and Humanoid's A2C (12,500 small iterations each) set the pace: on one H200 the two side by side
# took about 11.5 minutes (Ant, 16 seeds) and 647 s (Humanoid, 32 seeds).
#   PART=a2c:   ant a2c and humanoid a2c, 5 seeds in one vmapped program each, the two side by side;
#   PART=rest:  pusher npg, half_cheetah ppo, reacher trpo, swimmer trpo, one program after another (the
#               cheapest first; Swimmer last, as its fast preset is within 1 M env steps too);
#   PART=swimmer_fast: TRPO's swimmer_fast as typed, seed 0 bare, then seeds 0-2 warm, one process each;
#   PART=ant_anneal: ant a2c ant_1m with the learning rate annealed to 0 at 1 M, seeds 0-15 in one program;
#   PART=hopper_fast: Hopper's fast preset with docs/tasks.md's settings (PPO's hopper_gpu, 150 iterations)
#     through jaxpg.cli, as suite.py runs every task; seed 0 bare, then seeds 0-2 warm, each replayed in
#     Gymnasium: the suite table's H100 cell and the figure's Hopper panel (evaluated every 10 iterations,
#     15 times a run, for the curve; the preset: every 50);
#   PART=hopper_gpu: Hopper's time to 3000 (the "Time to a score" table, measured on an H200 so far),
#     PPO and NPG, seeds 0-2, caches filled first (--warmup); about 6 minutes.
# Each 1 M program's final mean policy (5 seeds; ant_anneal's 16) is replayed 10 episodes in Gymnasium v5, 16
# processes side by side (4 until LEASE=2: ant_anneal's 16 seeds must fit the lease).
# Start with setsid and poll for $D/done:
#   PART=a2c setsid nohup bash benchmarks/results/2026-12-05-gpu-unrun/suite_h100.sh > /tmp/suite.log 2>&1 < /dev/null &
D=${D:-/tmp/out}; R=/tmp/repo-suite; mkdir -p $D; rm -rf $R; cp -r "$PWD" $R; rm -rf $R/.w?? $R/.wc? $R/.whl; cd $R
export PYTHONPATH=$R:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; lscpu | grep 'Model name' >> $D/gpu.txt; date -u > $D/start.txt
git log -1 --format=%h >> $D/start.txt 2>/dev/null
python3 -m compileall -q -j 0 /tmp/site > $D/compileall.log 2>&1  # the bytecode a user's pip install writes
replay() {  # name, task
  python3 benchmarks/suite.py physics $(ls -d $D/runs/$1/$2-*/) --variants gymnasium \
    --episodes 10 --workers 16 --json $D/physics_$1.json > $D/physics_$1.log 2>&1
}
one_m() {  # task, algo
  python3 benchmarks/suite.py run --runs $1:$2:$1_1m --seeds 0 1 2 3 4 --vmap-seeds --episodes 0 \
    --out $D/runs/$1 --json $D/$1.json > $D/$1.log 2>&1
  date -u > $D/$1.end; replay $1 $1
}
case "${PART:-a2c}" in
  a2c) one_m ant a2c & one_m humanoid a2c & wait ;;
  rest) for run in pusher:npg half_cheetah:ppo reacher:trpo swimmer:trpo; do one_m ${run%:*} ${run#*:}; done ;;
  swimmer_fast)
    python3 benchmarks/suite.py run --runs swimmer:trpo:swimmer_fast --seeds 0 1 2 --bare-first --episodes 10 \
      --out $D/runs/swimmer_fast --json $D/swimmer_fast.json > $D/swimmer_fast.log 2>&1 ;;
  ant_anneal)  # ant_1m's A2C with its learning rate annealed to 0 at 1 M env steps (the preset then: at 3 M,
    # as Tianshou's; its own value since this ran), seeds 0-15 in one program: after one H100's seeds 0-4
    # fell back between 0.8 M and 1 M
    python3 benchmarks/suite.py run --runs ant:a2c:ant_1m --seeds $(seq 0 15) --vmap-seeds --episodes 0 \
      --out $D/runs/ant --json $D/ant.json --extra --anneal-lr-iterations 12500 > $D/ant.log 2>&1
    date -u > $D/ant.end; replay ant ant ;;
  hopper_fast)
    python3 benchmarks/suite.py run --runs hopper:ppo:hopper_gpu --seeds 0 1 2 --bare-first --episodes 10 \
      --out $D/runs/hopper_fast --json $D/hopper_fast.json --extra --iterations 150 --eval-every 10 \
      > $D/hopper_fast.log 2>&1 ;;
  hopper_gpu)
    for algo in ppo npg; do
      python3 benchmarks/time_to_return.py run --algo $algo --preset hopper_gpu --block 10 --iterations-per-call 1 \
        --seeds 0 1 2 --warmup --json $D/hopper_gpu_$algo.json > $D/hopper_gpu_$algo.log 2>&1
    done ;;
esac
touch $D/done
