# One H200 (16 host cores), JAX 0.11.2, MuJoCo/MJX 3.17.0, warp-lang 1.18.0, MuJoCo Warp; 2026-11-29,
# a freshly started machine; PyTorch and tensorboardX 2.6.5 in the path (both codes paid its import).
# "new": commit a83f6fe (metrics files and curves written on a background thread, Orbax imported on it
# during the first block; reverted in 47c54a0); "old": the same tree with jaxpg/run/session.py and
# callbacks.py of 41c325b. seed 0 of the `old` call is its first run (caches empty).
(cd new && python3 benchmarks/card_command.py card --seeds 0 1 2 --modes cold warm --out new --json new.json --extra --preset hopper_1m > new.log)
(cd old && python3 benchmarks/card_command.py card --seeds 0 1 2 3 --modes warm --out old --json old.json --extra --preset hopper_1m > old.log)
(cd new && python3 benchmarks/card_command.py card --seeds 3 4 5 --modes warm --out new --json new2.json --extra --preset hopper_1m > new2.log)
