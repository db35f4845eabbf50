# CPU: HalfCheetah within 1 M env steps, PPO with SB3 RL Zoo's tuned HalfCheetah settings (16 envs x 32 steps in place of 1 env x 512), 4 seeds in one program
. .venv/bin/activate; R=/tmp/hc_ppo; rm -rf $R; mkdir -p $R; echo "$(date +%T) start"
python -m jaxpg.cli --env half_cheetah --algo ppo --seeds 0 1 2 3 --num-envs 16 --horizon 32 --num-minibatches 8 --num-epochs 20 \
  --lr 2.0633e-05 --clip-eps 0.1 --gae-lambda 0.92 --gamma 0.98 --max-grad-norm 0.8 --value-coef 0.58096 --entropy-coef 0.000401762 \
  --log-std-init -2 --policy-hidden 256 256 --value-hidden 256 256 --policy-activation relu --value-activation relu \
  --normalize-observations --reward-scaling 0.05 --eval-envs 16 --eval-every 500 --iterations 1953 --run-dir $R/run --no-progress > $R/train.log 2>&1
echo "$(date +%T) trained rc $?"
for S in 0 1 2 3; do python -m jaxpg.evaluate $R/run --gymnasium --episodes 10 --train-seed $S > $R/gym$S.log 2>&1; echo "seed $S: $(tail -1 $R/gym$S.log)"; done
echo "$(date +%T) done"; touch $R/DONE
