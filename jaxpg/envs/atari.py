"""Atari Pong, the real game: the Arcade Learning Environment's ROM stepped on the host's CPU cores,
seen through Karpathy's (and MinPy's) preprocessing, behind jaxpg's functional env API.

``AtariPong`` is the task ``atari_pong``. Its games are ``ale_py``'s ``AtariVectorEnv`` with the
settings of Gymnasium's ``ALE/Pong-v5`` (four frames per step, the last frame observed, sticky
actions with probability 0.25, no no-op starts, no fire reset, rewards as the game gives them):
its frames equal ``ALE/Pong-v5``'s for the same seed and actions (tests/test_atari.py). The
games live on the host; ``step`` reaches them through ``jax.experimental.io_callback``, batched by
``jax.custom_batching.custom_vmap`` so that ``jax.vmap(env.step)`` over ``B`` envs makes *one*
call that steps all ``B`` games in ALE's C++ thread pool. The jitted learner (``jax.lax.scan``
over steps, the policy's forward pass, the update) runs as for any jaxpg task; only the emulator
is on the host (MinPy's setting).

Observation: ``[6400]`` float32 in ``{-1, 0, 1}``, the difference of the last two frames after
``preprocess`` (crop rows 35-194, every second row and column of the red channel, background
erased, the rest set to 1: Karpathy's ``prepro``). A game's first observation is all zeros (no
previous frame, Karpathy's ``np.zeros(D)``). 80x80 difference frames, not the DQN-style 84x84 stack
of four: this task reproduces MinPy's and Karpathy's experiment, whose 6400 -> 200 -> 2 network
``experiments/pong.py`` already trains on jaxpg's own Pong, and one difference frame carries the
ball's motion that a single frame lacks, at a quarter of a stack's input size.

Actions (``action_set``): ``"updown"`` (default, Karpathy's two: ALE's RIGHT = up and LEFT =
down), ``"stay"`` (NOOP, up, down) or ``"minimal"`` (ALE's six). An episode is one game to 21
points; the reward is +1 / -1 per point; ``metrics["task_score"]`` is the score difference so far.

How the host games follow jaxpg's episodes: a game that ends restarts at once on the host (ALE's
same-step autoreset), as ``AutoReset``'s fresh state does on the JAX side; and whenever ``step``
receives an env whose episode step counter is 0 while its host game has already been played,
that game is restarted first, which makes ``reset``/``reset_batch`` (episodic sampling, a new
evaluation) start new games. ``reset`` itself is pure (it cannot reach the host from inside
``AutoReset``, which computes a reset at every step). The host games are not part of any JAX state:
a checkpoint does not hold them, and a resumed run plays new games. Each batch size gets its own
pool of games, so train several seeds in separate processes, not in one ``vmap`` over seeds (the
command line refuses ``--seeds`` with several).

Needs the ``atari`` extra (``pip install 'jaxpg[atari]'``: ``ale-py``, ROMs included); without it,
``AtariPong()`` raises one ``ImportError`` line that names the install.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jax.experimental import io_callback

from jaxpg.envs.base import Env, State

INSTALL = "pip install 'jaxpg[atari]'"
GYMNASIUM_ID = "ALE/Pong-v5"
ROM = "pong"
FRAMESKIP = 4  # ALE/Pong-v5's
STICKY = 0.25  # ALE/Pong-v5's repeat_action_probability
FRAME_SHAPE = (210, 160, 3)
SIZE = 80  # preprocessed frames are SIZE x SIZE
BACKGROUND = (144, 109)  # red-channel values of Pong's two background shades
# Agent's action index -> ALE's minimal action set of Pong (0 NOOP, 1 FIRE, 2 RIGHT = up, 3 LEFT =
# down, 4 RIGHTFIRE, 5 LEFTFIRE).
ACTION_SETS: dict[str, tuple[int, ...]] = {
    "updown": (2, 3),
    "stay": (0, 2, 3),
    "minimal": (0, 1, 2, 3, 4, 5),
}


def require_ale() -> None:
    """``ImportError`` with one line naming the install unless ``ale_py`` can be imported."""
    try:
        import ale_py  # noqa: F401
    except ImportError:
        raise ImportError(f"atari_pong needs the Arcade Learning Environment (ale-py): {INSTALL}") from None


def preprocess(frames: Any) -> Any:
    """Karpathy's ``prepro``: ``[..., 210, 160, 3]`` uint8 RGB frames -> ``[..., 6400]`` float32 in {0, 1}.

    Crop to rows 35-194 (the court without the score), take every second row and column of the
    red channel (80x80), erase the background (red 144 and 109) and set everything else (paddles,
    ball) to 1. Works on NumPy arrays (on the host) and on JAX arrays (under ``jit``), with the
    same operations.
    """
    xp = jnp if isinstance(frames, jax.Array) else np
    red = frames[..., 35:195:2, ::2, 0]
    on = (red != BACKGROUND[0]) & (red != BACKGROUND[1])
    return xp.reshape(on.astype(xp.float32), on.shape[:-2] + (SIZE * SIZE,))


def make_ale_env(sticky: bool = True, frameskip: int = FRAMESKIP, render_mode: str | None = None) -> Any:
    """Gymnasium's ``ALE/Pong-v5`` (RGB frames), with its sticky actions (``repeat_action_probability``
    0.25) or without them (0), and ``frameskip`` emulator frames per step."""
    require_ale()
    import ale_py
    import gymnasium as gym

    gym.register_envs(ale_py)
    return gym.make(
        GYMNASIUM_ID,
        frameskip=frameskip,
        repeat_action_probability=STICKY if sticky else 0.0,
        render_mode=render_mode,
    )


def play_ale(
    act: Callable[[np.ndarray], np.ndarray],
    episodes: int,
    action_set: str = "updown",
    sticky: bool = True,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """``(scores [N], lengths [N])`` of ``episodes`` games of Gymnasium's ``ALE/Pong-v5`` played by
    ``act`` (observations ``[B, 6400]`` -> action indices ``[B]`` of ``action_set``), the games in
    lock-step. Game ``i`` is reset with seed ``seed + i``; observations are the frame differences
    of ``preprocess``, zeros first, as ``AtariPong`` gives them. A score is points won minus points
    lost (-21 to 21); a length counts agent steps (four frames each)."""
    games = [make_ale_env(sticky=sticky) for _ in range(episodes)]
    to_ale = np.asarray(ACTION_SETS[action_set])
    prev = np.stack([preprocess(g.reset(seed=seed + i)[0]) for i, g in enumerate(games)])
    obs = np.zeros_like(prev)
    scores, lengths = np.zeros(episodes), np.zeros(episodes, np.int64)
    alive = np.ones(episodes, bool)
    while alive.any():
        actions = np.asarray(act(obs))
        for i in np.flatnonzero(alive):
            frame, reward, terminated, truncated, _ = games[i].step(int(to_ale[actions[i]]))
            scores[i] += reward
            lengths[i] += 1
            current = preprocess(frame)
            obs[i], prev[i] = current - prev[i], current
            alive[i] = not (terminated or truncated)
    for g in games:
        g.close()
    return scores, lengths


class AlePool:
    """``num_envs`` Pong games in ALE's vector env, with the previous preprocessed frame of each.

    ``step(ale_actions [B], episode_steps [B])`` restarts the games whose jaxpg episode counter is
    0 but which have been played (see the module docstring), steps every game once, restarts the
    games that ended, and returns ``(obs [B, 6400] int8, reward [B] float32, terminated [B] bool)``,
    ``obs`` the difference of the preprocessed frames after and before the step.
    """

    def __init__(self, num_envs: int, sticky: bool, frameskip: int, max_frames: int, seed: int, num_threads: int = 0):
        from ale_py.vector_env import AtariVectorEnv

        self.env = AtariVectorEnv(
            ROM,
            num_envs,
            num_threads=num_threads,
            img_height=FRAME_SHAPE[0],
            img_width=FRAME_SHAPE[1],
            grayscale=False,
            stack_num=1,
            frameskip=frameskip,
            maxpool=False,
            noop_max=0,
            use_fire_reset=False,
            reward_clipping=False,
            repeat_action_probability=STICKY if sticky else 0.0,
            autoreset_mode="SameStep",
            max_num_frames_per_episode=max_frames,
        )
        frames, _ = self.env.reset(seed=seed)
        self.prev = preprocess(frames[:, 0]).astype(np.int8)
        self.played = np.zeros(num_envs, np.int64)  # steps of each host game so far

    def step(self, ale_actions: np.ndarray, episode_steps: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        restart = (episode_steps == 0) & (self.played > 0)
        if restart.any():
            frames, _ = self.env.reset(options={"reset_mask": restart})
            self.prev[restart] = preprocess(frames[restart, 0])
            self.played[restart] = 0
        frames, reward, terminated, truncated, info = self.env.step(ale_actions.astype(np.int32))
        frames = frames[:, 0]
        ended = terminated | truncated
        last = frames
        if ended.any():  # the ended games' last frames; ``frames`` holds their new games' first
            last = frames.copy()
            last[ended] = info["final_obs"][ended, 0]
        current = preprocess(last).astype(np.int8)
        obs = current - self.prev
        self.prev = current
        if ended.any():
            self.prev[ended] = preprocess(frames[ended])
        self.played = np.where(ended, 0, self.played + 1)
        return obs, reward.astype(np.float32), terminated.astype(bool)


def batched_host_call(host: Callable[..., tuple], out_shapes: Callable[[tuple[int, ...]], tuple]) -> Callable:
    """``f(*args)`` calling ``host`` through ``io_callback``, once per ``vmap``: under ``jax.vmap``
    the host gets the whole batch (leading axis ``B`` on every argument) in one call instead of
    ``B`` calls. ``out_shapes(batch_shape)`` gives the ``jax.ShapeDtypeStruct`` of each output."""

    @jax.custom_batching.custom_vmap
    def call(*args: jax.Array) -> tuple:
        return io_callback(host, out_shapes(()), *args)

    @call.def_vmap
    def _batched(axis_size: int, in_batched: list[bool], *args: jax.Array) -> tuple[tuple, tuple]:
        args = tuple(
            a if batched else jnp.broadcast_to(a, (axis_size,) + a.shape)
            for a, batched in zip(args, in_batched, strict=True)
        )
        out = io_callback(host, out_shapes((axis_size,)), *args)
        return out, tuple(True for _ in out)

    return call


class AtariPong(Env):
    """Atari Pong (the ALE ROM) from 80x80 frame differences; see the module docstring.

    Args:
      action_set: ``"updown"`` (2 actions), ``"stay"`` (3) or ``"minimal"`` (ALE's 6).
      sticky: sticky actions with probability 0.25 (``ALE/Pong-v5``'s default); ``False``: none.
      frameskip: emulator frames per step (4, as ``ALE/Pong-v5``).
      max_episode_steps: steps that truncate a game (27000 = ALE's limit of 108000 frames).
      seed: seed of the host games (each batch size's pool is seeded with it).
      num_threads: ALE's threads stepping the games (0: ALE's default, one per core).
    """

    discrete = True
    task_score_name = "score_difference"
    observation_size = SIZE * SIZE
    image_shape = (SIZE, SIZE, 1)
    vmap_seeds = False  # seeds vmapped in one program would share one pool of host games

    def __init__(
        self,
        action_set: str = "updown",
        sticky: bool = True,
        frameskip: int = FRAMESKIP,
        max_episode_steps: int = 27_000,
        seed: int = 0,
        num_threads: int = 0,
    ):
        require_ale()
        if action_set not in ACTION_SETS:
            raise ValueError(f"action_set must be one of {', '.join(ACTION_SETS)}, got {action_set!r}")
        if frameskip < 1 or max_episode_steps < 1:
            raise ValueError(f"frameskip and max_episode_steps must be >= 1, got {frameskip}, {max_episode_steps}")
        self.action_set = action_set
        self.ale_actions = np.asarray(ACTION_SETS[action_set], np.int32)
        self.action_size = len(self.ale_actions)
        self.sticky, self.frameskip, self.seed, self.num_threads = bool(sticky), frameskip, seed, num_threads
        self.max_episode_steps = max_episode_steps
        self.dt = frameskip / 60.0  # the console's 60 frames per second
        self.pools: dict[int, AlePool] = {}
        self._host_step = batched_host_call(self._host, self._out_shapes)

    def pool(self, num_envs: int) -> AlePool:
        """The host games of batch size ``num_envs`` (made, and reset, on first use)."""
        if num_envs not in self.pools:
            # ALE's own limit lies past jaxpg's, which truncates (and so restarts) games first.
            max_frames = (self.max_episode_steps + 1) * self.frameskip * 2
            self.pools[num_envs] = AlePool(
                num_envs, self.sticky, self.frameskip, max_frames, self.seed, self.num_threads
            )
        return self.pools[num_envs]

    def _out_shapes(self, batch: tuple[int, ...]) -> tuple[jax.ShapeDtypeStruct, ...]:
        return (
            jax.ShapeDtypeStruct(batch + (self.observation_size,), jnp.int8),
            jax.ShapeDtypeStruct(batch, jnp.float32),
            jax.ShapeDtypeStruct(batch, jnp.bool_),
        )

    def _host(self, actions: np.ndarray, episode_steps: np.ndarray) -> tuple[np.ndarray, ...]:
        """Host side of ``step``: actions ``[]`` or ``[B]`` (agent indices) -> ALE's games."""
        actions, episode_steps = np.asarray(actions), np.asarray(episode_steps)
        single = actions.ndim == 0
        actions, episode_steps = np.atleast_1d(actions), np.atleast_1d(episode_steps)
        obs, reward, terminated = self.pool(actions.shape[0]).step(self.ale_actions[actions], episode_steps)
        if single:
            return obs[0], reward[0], terminated[0]
        return obs, reward, terminated

    def _metrics(self, score: jax.Array) -> dict[str, jax.Array]:
        return {"task_score": (score[0] - score[1]).astype(jnp.float32)}

    def _reset(self, key: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        del key  # the host games are seeded once, by ``seed``
        score = jnp.zeros((2,), jnp.int32)
        return {"score": score}, jnp.zeros((self.observation_size,), jnp.float32), self._metrics(score)

    def _step(self, state: State, action: jax.Array) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict]:
        obs, reward, terminated = self._host_step(action.astype(jnp.int32), state.info["step"])
        won, lost = reward > 0, reward < 0
        score = state.data["score"] + jnp.stack([won, lost]).astype(jnp.int32)
        return {"score": score}, obs.astype(jnp.float32), reward, terminated, self._metrics(score)

    def __repr__(self) -> str:
        sticky = "sticky" if self.sticky else "no sticky"
        return f"AtariPong(ALE {GYMNASIUM_ID}, {self.action_set} actions, {sticky}, frameskip {self.frameskip})"
