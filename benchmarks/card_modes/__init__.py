"""The modes of ``benchmarks/card_command.py``, one module each (``card``, ``determinism``, ``kernels``,
``capture``, ``startup``, ``memory``, ``parts``): each holds its measurement, its table and its command
line (``<mode>_main(argv)``), beside the card's command and the paths they share. They import
``harness`` as the scripts do, so ``benchmarks/`` must be on ``sys.path`` (as it is when
``python benchmarks/card_command.py`` runs)."""

from pathlib import Path

CARD_COMMAND = ("experiments/hopper.py", "--num-envs", "256")  # from the repository root
ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "benchmarks" / "card_command.py"  # the command line whose modes run in child processes
