"""Does jaxtari's Pong play like the real game? Object positions against ALE's Pong, frame by frame.

Both games start from their reset and take the same action sequence, one emulator frame per step
(ALE: ``ALE/Pong-v5`` with ``frameskip=1, repeat_action_probability=0``; jaxtari:
``jaxtari.games.jax_pong.JaxPong`` stepped under ``jit``). From ALE's RGB frames the objects are
read off by colour (the agent's green paddle in columns 140-143, the opponent's orange one in
columns 16-19, the white ball inside the court, rows 34-193); jaxtari's state is drawn as the same
rectangles, clipped to the same court, and read off by the same function, so the two columns of
the table measure the same thing. jaxtari's own renderer needs a sprite pack downloaded from outside
the package registries (``python -m jaxtari.install_sprites``), so it is bypassed here.

Printed per block of steps: mean absolute differences (pixels) of the visible tops of the two
paddles and of the ball's corner, where both games show the object; the share of steps where one
shows an object the other does not; and the pixels of the 80x80 binarised frames
(``jaxpg.envs.atari.preprocess``) that disagree. Then the steps at which each game scored points.

    python benchmarks/jaxtari_vs_ale.py                      # 600 steps, three action sequences
    python benchmarks/jaxtari_vs_ale.py --steps 2000 --block 250
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

import numpy as np

from jaxpg.envs import atari

COURT_TOP, COURT_BOTTOM = 34, 194  # rows of the court between the white walls
PLAYER_COLS, ENEMY_COLS = slice(140, 144), slice(16, 20)
PLAYER_RGB, ENEMY_RGB, BALL_RGB = (92, 186, 92), (213, 130, 74), (236, 236, 236)
BACKGROUND_RGB = (144, 72, 17)


def objects(frame: np.ndarray) -> np.ndarray:
    """``[4]`` float: visible top rows of the agent's and the opponent's paddles, the ball's left
    column and top row, read from one ``[210, 160, 3]`` frame (NaN where the object is not seen)."""
    court = frame[COURT_TOP:COURT_BOTTOM]
    out = np.full(4, np.nan)
    for i, (rgb, cols) in enumerate(((PLAYER_RGB, PLAYER_COLS), (ENEMY_RGB, ENEMY_COLS))):
        rows = np.flatnonzero(np.all(court[:, cols] == rgb, axis=-1).any(axis=1))
        if rows.size:
            out[i] = rows[0] + COURT_TOP
    ys, xs = np.nonzero(np.all(court == BALL_RGB, axis=-1))
    if ys.size:
        out[2], out[3] = xs.min(), ys.min() + COURT_TOP
    return out


def draw(player_y: float, enemy_y: int, ball_x: int, ball_y: int, ball_visible: bool) -> np.ndarray:
    """``[210, 160, 3]`` uint8: jaxtari's objects as rectangles of its sizes (paddles 4x16, ball
    2x4) on Pong's background, clipped to the court as ALE shows them; no walls, no score."""
    frame = np.empty((210, 160, 3), np.uint8)
    frame[:] = BACKGROUND_RGB
    mask = np.zeros((210, 160), bool)

    def rect(x: int, y: int, w: int, h: int, rgb: tuple[int, int, int]) -> None:
        mask[:] = False
        mask[max(y, COURT_TOP) : min(y + h, COURT_BOTTOM), max(x, 0) : x + w] = True
        frame[mask] = rgb

    rect(140, int(round(player_y)), 4, 16, PLAYER_RGB)
    rect(16, int(enemy_y), 4, 16, ENEMY_RGB)
    if ball_visible:
        rect(int(ball_x), int(ball_y), 2, 4, BALL_RGB)
    return frame


def bare_jaxtari_pong() -> Any:
    """jaxtari's ``JaxPong`` without its renderer (which loads the downloaded sprites)."""
    from jaxtari.environment import JaxEnvironment
    from jaxtari.games import jax_pong

    class BarePong(jax_pong.JaxPong):
        def __init__(self) -> None:
            JaxEnvironment.__init__(self, jax_pong.PongConstants())

    return BarePong()


def play_ale(actions: np.ndarray, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """ALE's frames after each action, ``[T, 210, 160, 3]``, and rewards ``[T]``."""
    env = atari.make_ale_env(sticky=False, frameskip=1)
    env.reset(seed=seed)
    frames, rewards = [], []
    for a in actions:
        obs, r, terminated, truncated, _ = env.step(int(a))
        frames.append(obs)
        rewards.append(r)
        if terminated or truncated:
            break
    env.close()
    return np.stack(frames), np.asarray(rewards)


def play_jaxtari(actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """jaxtari's frames (``draw``) after each action, ``[T, 210, 160, 3]``, and rewards ``[T]``."""
    import jax
    import jax.numpy as jnp

    env = bare_jaxtari_pong()

    @jax.jit
    def run(acts: jax.Array) -> tuple[Any, jax.Array]:
        _, state = env.reset(jax.random.PRNGKey(0))

        def body(s: Any, a: jax.Array) -> tuple[Any, tuple]:
            _, s, reward, _, _ = env.step(s, a)
            # The ball waits at the serve spot, hidden, for the first 60 steps after a point.
            return s, (s.player_y, s.enemy_y, s.ball_x, s.ball_y, s.step_counter >= 60, reward)

        return jax.lax.scan(body, state, acts)[1]

    py, ey, bx, by, seen, rewards = jax.device_get(run(jnp.asarray(actions, jnp.int32)))
    frames = np.stack([draw(*args) for args in zip(py, ey, bx, by, seen, strict=True)])
    return frames, np.asarray(rewards, np.float64)


def action_sequences(steps: int, seed: int) -> dict[str, np.ndarray]:
    """Named action sequences over Pong's six actions (0 NOOP, 1 FIRE, 2 RIGHT = up, 3 LEFT =
    down, 4 RIGHTFIRE, 5 LEFTFIRE)."""
    rng = np.random.default_rng(seed)
    held = np.repeat(rng.integers(0, 6, size=steps // 8 + 1), 8)[:steps]
    return {
        "noop": np.zeros(steps, np.int32),
        "up 30 / down 30": np.where((np.arange(steps) // 30) % 2 == 0, 2, 3).astype(np.int32),
        "random, held 8": held.astype(np.int32),
    }


def compare(actions: np.ndarray, block: int) -> tuple[list[list[str]], str]:
    """Table rows (one per block of steps) and a line on the scored points."""
    ale_frames, ale_rewards = play_ale(actions)
    jt_frames, jt_rewards = play_jaxtari(actions[: len(ale_frames)])
    a = np.stack([objects(f) for f in ale_frames])
    j = np.stack([objects(f) for f in jt_frames])
    pixels = np.sum(atari.preprocess(ale_frames) != atari.preprocess(jt_frames), axis=-1)
    rows = []
    for start in range(0, len(a), block):
        sl = slice(start, start + block)
        both = ~np.isnan(a[sl]) & ~np.isnan(j[sl])
        diff = np.abs(np.where(both, a[sl] - j[sl], 0.0))
        means = [np.sum(diff[:, k]) / max(np.sum(both[:, k]), 1) for k in range(4)]
        seen_apart = np.mean(np.isnan(a[sl, 2]) != np.isnan(j[sl, 2]))
        rows.append(
            [f"{start}-{min(start + block, len(a)) - 1}"]
            + [f"{m:.1f}" if np.any(both[:, k]) else "-" for k, m in enumerate(means)]
            + [f"{seen_apart:.2f}", f"{np.mean(pixels[sl]):.1f}"]
        )
    points = (
        f"points (step:reward) ALE {_points(ale_rewards)}; jaxtari {_points(jt_rewards)}"
        if np.any(ale_rewards) or np.any(jt_rewards)
        else "no point scored in either game"
    )
    return rows, points


def _points(rewards: np.ndarray) -> str:
    steps = np.flatnonzero(rewards)
    return " ".join(f"{s}:{int(rewards[s]):+d}" for s in steps[:8]) or "none"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=600, help="emulator frames per sequence")
    parser.add_argument("--block", type=int, default=100, help="steps per table row")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random action sequence")
    args = parser.parse_args(argv)
    atari.require_ale()
    header = ["steps", "|d player y|", "|d enemy y|", "|d ball x|", "|d ball y|", "ball seen apart", "80x80 px"]
    for name, actions in action_sequences(args.steps, args.seed).items():
        rows, points = compare(actions, args.block)
        print(f"\nactions: {name}  (mean absolute differences in pixels of the 210x160 frame)")
        widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
        print("  ".join(h.rjust(w) for h, w in zip(header, widths, strict=True)))
        for row in rows:
            print("  ".join(c.rjust(w) for c, w in zip(row, widths, strict=True)))
        print(points)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
