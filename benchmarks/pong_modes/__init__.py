"""The measurements of ``benchmarks/pong.py`` (its command line): ``fps`` (jaxpg Pong's frames per
second), ``runs`` (A2C or PPO runs and their running reward), ``plots`` (running reward against wall
clock) and ``atari_fps`` (the Atari ROM's paths). They import ``harness`` as the scripts do, so
``benchmarks/`` must be on ``sys.path`` (as it is when ``python benchmarks/pong.py`` runs)."""
