# 2 CPU cores (one of them busy with a 4-seed HalfCheetah training run), JAX 0.10.2, 2026-11-29.
PYTHONPATH=. python benchmarks/throughput.py host --seeds 32 --iterations 12500 --repeats 3 \
  --state humanoid:a2c:humanoid_1m --json benchmarks/results/2026-11-29-cpu-host-work/host.json
