# 2 CPU cores (AMD EPYC), JAX 0.10.2, MuJoCo 3.17.0, Gymnasium 1.4.0, SciPy 1.17.1, 2026-12-05, the code at 11ead64.
# How far is a trained Reacher policy from the best open-loop plans that MuJoCo's own physics allows, and what
# does Tianshou's reported metric (the highest point of a 10-seed mean curve) add to a flat curve?
# Reacher-v5 is deterministic after its reset, so for each episode a plan of 50 actions optimised with the
# true model is a policy for that episode. adj.py: the episode cost (distance after each step + |a|^2, as
# v5 counts it, checked against Gymnasium's own returns to 4e-6) and its gradient, by the adjoint of each
# env step's finite-difference linearisation in MuJoCo (RK4, the joint limit included; checked against
# central differences of the cost to 1e-9). Each plan is L-BFGS-B within [-1, 1] and replayed in Gymnasium.
# 1. the policy: TRPO's reacher_1m, seeds 0 and 1 in one program (134 s of training)
python -m jaxpg.cli --env reacher --algo trpo --preset reacher_1m --seeds 0 1 --run-dir runs/trpo --no-progress > train_trpo.log
# 2. zero and random starts (3 per episode), one core each; stopped after 9 episodes each
taskset -c 0 python lbfgs_random.py 1000 25 3 > random_starts_1000.log
taskset -c 1 python lbfgs_random.py 1025 25 3 > random_starts_1025.log
# 3. starts from the policy's own actions, zero, and four pushes; 40 episodes, one core each
taskset -c 0 python lbfgs.py 1000 20 runs/trpo 0 > policy_starts_1000.log
taskset -c 1 python lbfgs.py 1020 20 runs/trpo 0 > policy_starts_1020.log
python summarise.py policy_starts_1000.log policy_starts_1020.log random_starts_1000.log random_starts_1025.log > summary_40.txt
# 4. more starts on 10 episodes (policy, zero, 8 pushes, 14 random): does the best keep improving?
taskset -c 0 python lbfgs_many.py 1000 5 runs/trpo 0 14 > many_starts_1000.log
taskset -c 1 python lbfgs_many.py 1005 5 runs/trpo 0 14 > many_starts_1005.log
# 5. the same policy trained longer (2 M and 4 M env steps) and wider (256x256), two programs side by side, one
#    core each; then every policy over the same 40 episodes in Gymnasium
taskset -c 0 python -m jaxpg.cli --env reacher --algo trpo --preset reacher_1m --seeds 0 1 --policy-hidden 256 256 --run-dir runs/wide --no-progress > train_trpo_wide.log
taskset -c 1 python -m jaxpg.cli --env reacher --algo trpo --preset reacher_1m --seeds 0 1 --iterations 976 --run-dir runs/long --no-progress > train_trpo_long.log
taskset -c 1 python -m jaxpg.cli --env reacher --algo trpo --preset reacher_1m --seeds 0 1 --iterations 1952 --run-dir runs/long4 --no-progress > train_trpo_long4.log
for r in trpo long long4 wide; do python eval40.py runs/$r 0,1 1000 40; done > eval40.log
# 6. plans started from the seven other policies' own actions (five of them beat the plans above on 1-3 episodes)
P="runs/trpo:1 runs/long:0 runs/long:1 runs/long4:0 runs/long4:1 runs/wide:0 runs/wide:1"
taskset -c 0 python lbfgs_policies.py 1000 20 $P > policy_family_starts_1000.log
taskset -c 1 python lbfgs_policies.py 1020 20 $P > policy_family_starts_1020.log
L="policy_starts_1000.log policy_starts_1020.log random_starts_1000.log random_starts_1025.log many_starts_1000.log many_starts_1005.log policy_family_starts_1000.log policy_family_starts_1020.log"
python summarise.py $L > summary.txt
python compare_policies.py eval40.log $L > compare.txt
# 7. larger updates: 8 envs x 1024 steps (8192 samples an update, four times the preset's) for the 2 M run's
#    976 updates (8 M env steps), both cores; its policies appended to eval40.log, compare.txt written again
python -m jaxpg.cli --env reacher --algo trpo --preset reacher_1m --seeds 0 1 --num-envs 8 --iterations 976 --run-dir runs/big8 --no-progress > train_trpo_big8.log
python eval40.py runs/big8 0,1 1000 40 >> eval40.log
# 8. updates 16 times as large: 32 envs x 1024 steps (32768 samples) for 488 updates (16 M env steps), both cores
python -m jaxpg.cli --env reacher --algo trpo --preset reacher_1m --seeds 0 1 --num-envs 32 --iterations 488 --run-dir runs/big32 --no-progress > train_trpo_big32.log
python eval40.py runs/big32 0,1 1000 40 >> eval40.log
python compare_policies.py eval40.log $L > compare.txt
# 9. the same 32768 samples in the GPU's shape: 512 envs x 64 steps, the value fit in minibatches of 1024
python -m jaxpg.cli --env reacher --algo trpo --preset reacher_1m --seeds 0 1 --num-envs 512 --horizon 64 --value-batch-size 1024 --iterations 488 --run-dir runs/big512 --no-progress > train_trpo_big512.log
python eval40.py runs/big512 0,1 1000 40 > eval40_big512.log
# Ran as above. summary_40.txt (steps 1-3): the best plans -3.330 over 40 episodes, the seed-0 policy -3.753;
# 24 starts on episodes 1000-1009 changed one episode's best (1002). Then (eval40.log) five of the other seven
# policies beat those plans on 1-3 episodes each, and step 6 lifted the best plans to -3.251 (summary.txt,
# compare.txt), above every policy in every episode. Step 7: 8192 samples an update for 976 updates scored
# -3.43 and -3.39, within 0.18 and 0.13 of the plans; step 8, 32768 samples for 488 updates, -3.39 and -3.38.
# Training: 1 M 134 s, 2 M 237 s, 4 M 467 s, 256x256 561 s, 8192 x 976 887 s, 32768 x 488 1728 s.
# The scripts were formatted for ruff after the runs (line breaks, type hints, the scipy objective moved
# into adj.objective); what they compute is unchanged.
# Later, the scripts' shared steps moved into adj.py (improve: the L-BFGS-B call; replay: a plan played in
# Gymnasium; policy_episode: a policy played closed loop). Rerun after that move, each script's first line
# (episode 1000; eval40.py runs/trpo seed 0) matched its log to the last digit.
# Step 9 (a later session, same day): -3.41 and -3.47 on the 40 episodes, 1848 s for both seeds in one program.

# The one-off Python this ran (adj.py compare_policies.py eval40.py lbfgs.py lbfgs_many.py lbfgs_policies.py lbfgs_random.py summarise.py ) left the tree when results/ became records and commands only;
# it is at commit 20ac6f2: git show 20ac6f2:benchmarks/results/2026-12-05-cpu-reacher-plans/NAME.py
