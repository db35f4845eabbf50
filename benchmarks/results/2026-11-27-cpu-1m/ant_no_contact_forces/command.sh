# CPU (2 cores), MJX JAX implementation: PPO on Ant within 1 M env steps (Tianshou-like small batches, as anP),
# with the contact forces left out of the observation (Ant-v3 effectively had them all zero). Neither the
# command line nor the Gymnasium replay passes the env keyword yet, so two throwaway scripts do:
R=/tmp/cpus; name=anN; mkdir -p $R
cat > /tmp/ant_nocfrc.py <<'PY'
"""Throwaway: train PPO on Ant without the contact forces in the observation (Ant-v3's effective obs)."""
from jaxpg.cli import Experiment, exit_process, main

exit_process(main(experiment=Experiment(task="ant", tasks=("ant",), algo="ppo", iterations=488,
                                        env_kwargs={"include_cfrc_ext_in_observation": False}, prog="ant_nocfrc")))
PY
cat > /tmp/ant_nocfrc_eval.py <<'PY'
"""Throwaway: jaxpg.evaluate --gymnasium against Ant-v5 without contact forces in the observation."""
import sys

import gymnasium as gym

import jaxpg.run.replay as replay
from jaxpg.run.evaluate_cli import main

replay.gymnasium_reference_env = lambda task, kw, render=False: gym.make("Ant-v5", include_cfrc_ext_in_observation=False)
sys.exit(main(sys.argv[1:]))
PY
/usr/bin/time -f "%e s" python /tmp/ant_nocfrc.py --seeds 0 1 --num-envs 16 --horizon 128 --iterations 488 \
    --num-epochs 10 --num-minibatches 32 --lr 3e-4 --anneal-lr-iterations 488 --gamma 0.99 --gae-lambda 0.95 \
    --normalize-observations --policy-hidden 64 64 --value-hidden 64 64 --policy-activation tanh --value-activation tanh \
    --max-grad-norm 0.5 --eval-envs 16 --eval-every 122 --log-std-init -0.5 --run-dir $R/$name --overwrite > $R/$name.log 2>&1
for s in 0 1; do JAX_PLATFORMS=cpu JAXPG_COMPILATION_CACHE=off python /tmp/ant_nocfrc_eval.py $R/$name --gymnasium --episodes 10 --train-seed $s > $R/$name-g$s.log 2>&1; done
# seeds 2 and 3: the same with name=anN23, --seeds 2 3 and the evaluation loop over 2 3
# anNv: the same as anN (seeds 0 1) with --normalize-value-targets --value-coef 0.25 added
