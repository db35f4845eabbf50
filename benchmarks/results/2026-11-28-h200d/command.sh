# One H200 (16 host cores), a freshly started machine, JAX 0.11.2, MuJoCo/MJX 3.17.0, warp-lang 1.18.0,
# 2026-11-28. The card's command as typed (1.97 M env steps): three bare-machine runs (card_command.py gives
# each empty XLA, MuJoCo Warp kernel and CUDA driver caches), then three warm runs.
python benchmarks/card_command.py card --seeds 0 1 2 --modes cold warm --out card --json card.json > card.log 2>&1
