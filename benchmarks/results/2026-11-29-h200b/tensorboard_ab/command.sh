# One H200 (16 host cores), JAX 0.11.2, MuJoCo/MJX 3.17.0, warp-lang 1.18.0, MuJoCo Warp; 2026-11-29,
# a freshly started machine. The GPU image has PyTorch; tensorboardX 2.6.5 was installed beside MJX,
# as a user's `pip install jaxpg` did before (tensorboardX was a dependency).
# "new": this commit's tree (jaxpg.run.tensorboard writes the event files); "old": the same tree with
# jaxpg/run/metrics_log.py and layout.py of 41c325b (tensorboardX's SummaryWriter).
# In each `card` call seed 0 is the first run (its caches empty: not a warm run); the rest are warm.
PYTHONPATH=/tmp/site python3 -X importtime -c "import tensorboardX" 2> tbx_importtime.txt   # top: tbx_importtime_top.txt
PYTHONPATH=/tmp/site python3 -c "import time; t=time.perf_counter(); import tensorboardX; print('import tensorboardX', time.perf_counter()-t); import sys; print('torch imported:', 'torch' in sys.modules)"
(cd new && python3 benchmarks/card_command.py card --seeds 0 1 2 3 --modes warm --out new --json new.json --extra --preset hopper_1m > new.log)
(cd old && python3 benchmarks/card_command.py card --seeds 0 1 2 3 --modes warm --out old --json old.json --extra --preset hopper_1m > old.log)
(cd new && python3 benchmarks/card_command.py card --seeds 4 5 --modes warm --out new --json new2.json --extra --preset hopper_1m > new2.log)
