# 2x H200 (kind nvidia-h200-x2, 32 host cores), JAX 0.11.2, MJX 3.17.0, warp-lang 1.18.0, 2026-11-28.
# 1. GPU 0: Swimmer's fast preset, whole process, the first seed with empty caches, then 3 seeds warm (time.json, time.log).
#    GPU 1 trained the 2 M-step RK4 program of step 2 beside it (that machine was then lost, with it).
CUDA_VISIBLE_DEVICES=0 python benchmarks/suite.py run --runs swimmer:trpo:swimmer_fast --seeds 0 1 2 --bare-first --json time.json
# 2. A second machine: the preset trained in Gymnasium's RK4, 8 seeds in one program per GPU, 1.5 M (GPU 1) and 2 M (GPU 0)
#    env steps; stopped at iterations 670 of 732 / 640 of 976 when the session's device time ran out. Their in-run
#    mean-policy evaluations (16 episodes every 50 iterations) are in swimmer_rk4_in_run.json.
S="0 1 2 3 4 5 6 7"
CUDA_VISIBLE_DEVICES=1 python benchmarks/suite.py run --runs swimmer:trpo:swimmer_fast --seeds $S --vmap-seeds --extra --fidelity gymnasium --iterations 732
CUDA_VISIBLE_DEVICES=0 python benchmarks/suite.py run --runs swimmer:trpo:swimmer_fast --seeds $S --vmap-seeds --extra --fidelity gymnasium --iterations 976
# 3. On the CPU: the 1.5 M program's checkpoint at iteration 650 replayed in Gymnasium (seeds 0, 3, 6):
#    python -m jaxpg.evaluate RUN --gymnasium --episodes 10 --train-seed S   (gym_rk4_650.log)
