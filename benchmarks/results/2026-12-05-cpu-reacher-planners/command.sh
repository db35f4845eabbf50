# 2 CPU cores, JAX 0.10.2, MJX 3.17.0 (its JAX implementation), Gymnasium 1.4.0 (MuJoCo 3.17.0), 2026-12-05,
# the code at acab5c1. Where a Reacher policy's return goes, and two planners with Gymnasium's own model.
# 1. reacher_1m with TRPO (the Zoo's settings), seeds 0-3 in one program (228 s of training)
python -m jaxpg.cli --env reacher --algo trpo --preset reacher_1m --seeds 0 1 2 3 --run-dir run-base --no-progress > train_trpo.log
# 2. each final policy over 50 Gymnasium episodes (reset seeds 1000-1049): distance and control cost, and
#    the mean distance at chosen steps
for S in 0 1 2 3; do python decompose.py run-base $S 50; done > decompose.log
# 3. the cross-entropy method at every step (25-step plans, 512 x 8 rounds), episodes 1000-1009, the two
#    halves side by side, one core each
POP=512 ELITE=32 ITERS=8 taskset -c 0 python reacher_mpc.py 25 0,1,2,3,4 > cem_episodes0-4.log
POP=512 ELITE=32 ITERS=8 taskset -c 1 python reacher_mpc.py 25 5,6,7,8,9 > cem_episodes5-9.log
# 4. gradient descent on all 50 actions through MJX: from zero actions (300 Adam steps at 0.05), and from
#    TRPO seed 3's own actions (1000 steps at 0.01); output as the script printed it
python reacher_gradopt.py 0,1,2,3,4,5,6,7,8,9 300 1 0.05 > gradopt_from_zero.log
python reacher_gradopt.py 0,1,2,3,4,5,6,7,8,9 1000 1 0.01 run-base 3 > gradopt_from_trpo_seed3.log
# the same from TRPO seed 3's actions, episode 1000 alone, 2 Adam steps (the replay of the policy's own
# actions there, open-loop, scores its closed-loop -3.139)
python reacher_gradopt.py 0 2 1 0.01 run-base 3 > gradopt_two_steps_episode0.log
# Ran as above. TRPO seed 3 on episodes 1000-1009 scores -3.139 -2.410 -5.067 -2.100 -2.823 -6.051 -2.264
# -2.752 -3.584 -1.675 (mean -3.187; seed 0: -3.276); CEM -3.357; gradient descent from zero -7.379, from
# the policy -3.151.

# The one-off Python this ran (decompose.py reacher_gradopt.py reacher_mpc.py ) left the tree when results/ became records and commands only;
# it is at commit 20ac6f2: git show 20ac6f2:benchmarks/results/2026-12-05-cpu-reacher-planners/NAME.py
