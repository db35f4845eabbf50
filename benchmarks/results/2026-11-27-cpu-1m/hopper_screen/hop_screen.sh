# CPU screen of hopper_1m variants: 8 seeds vmapped in one program, each seed scored in Gymnasium (10 episodes)
. .venv/bin/activate; R=/tmp/hops; mkdir -p $R
v() { name=$1; shift
  /usr/bin/time -f "%e s" python -m jaxpg.cli --env hopper --preset hopper_1m --seeds 0 1 2 3 4 5 6 7 --no-progress --log-every 20 "$@" --run-dir $R/$name --overwrite > $R/$name.log 2>&1
  for s in 0 1 2 3 4 5 6 7; do JAX_PLATFORMS=cpu JAXPG_COMPILATION_CACHE=off python -m jaxpg.evaluate $R/$name --gymnasium --episodes 10 --train-seed $s > $R/$name-g$s.log 2>&1 & if [ $((s % 2)) = 1 ]; then wait; fi; done; wait
  echo "$(date +%T) $name $* : $(tail -1 $R/$name.log) | gym: $(for s in 0 1 2 3 4 5 6 7; do grep -oP '^return: \S+' $R/$name-g$s.log | cut -d' ' -f2; done | tr '\n' ' ')"; }
for cfg in "$@"; do eval "v $cfg"; done
touch $R/DONE
