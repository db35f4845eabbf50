"""``python -m jaxpg.evaluate RUN_DIR ...``: evaluate a trained policy (``jaxpg.run.evaluation.evaluate_cli``).

Episodes in jaxpg's env: ``jaxpg.run.evaluation.policy_episodes``; in Gymnasium's or ALE's:
``jaxpg.run.evaluation.replay``.
"""

from __future__ import annotations

from jaxpg.run.evaluation.evaluate_cli import main

__all__ = ["main"]

if __name__ == "__main__":
    raise SystemExit(main(owns_process=True))
