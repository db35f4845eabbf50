"""Pong from pixels: a two-paddle Pong written in pure JAX for jaxpg (it is *not* the Atari ROM).

This is a small Pong of our own, made so that thousands of games run in one ``vmap`` and the
MinPy / Karpathy "Pong from pixels" experiment (policy gradient, then parallel A2C) can be reproduced without an
emulator. It plays like Atari Pong but is not pixel- or rule-identical to it, and scores on it are
not comparable with Atari Pong scores.

The court is the unit square, ``x`` to the right and ``y`` *down* (image rows). The agent's
paddle is on the right, a scripted opponent's on the left. Every step:
  1. the agent's paddle moves ``paddle_speed`` up or down (or stays, with ``stay_action``),
     clamped to the court;
  2. the opponent's paddle moves toward the ball's height by at most ``opponent_speed``: a speed
     limit, so a fast, steep ball beats it;
  3. the ball moves by its velocity and reflects off the top and bottom walls;
  4. a ball that crosses the front face of a paddle within the paddle's height (the ball's half
     size included) bounces back, faster by the factor ``speedup`` (up to ``max_ball_speed``),
     leaving at an angle set by where it hit the paddle: up to ``max_bounce_angle`` from the
     horizontal at the paddle's ends, straight at its centre;
  5. a ball that reaches the left edge of the court scores a point for the agent (reward +1),
     the right edge one for the opponent (reward -1); the ball is then served again from the
     centre line (random height in ``[0.25, 0.75]``, random side, angle within
     ``serve_angle`` of the horizontal, speed ``ball_speed``). Paddles stay where they are.
The game *terminates* when either side reaches ``winning_score`` (21) points and is *truncated*
at ``max_episode_steps``. ``metrics["task_score"]`` is the score difference (agent minus
opponent) so far: at the end of a game, its final score difference. ``metrics["hit"]`` is 1 on the
steps where the agent's paddle returned the ball.

Observations are frames ``[size * size]`` (row-major ``[size, size]`` images, float32 in
``[0, 1]``, one channel, ``size = 80`` by default) drawn inside JAX: each object is an
axis-aligned rectangle whose image is the outer product of its per-row and per-column coverage
(the fraction of each pixel the rectangle covers), so that drawing is exact anti-aliasing, costs
``O(size^2)`` per object with no loop and no gather, and ``vmap``s over games. Physics is in court
units, so ``size`` (e.g. 40 for quick tests) changes the picture's resolution but not the game.
Actions: ``0`` up, ``1`` down (``action_size`` 2), or with ``stay_action=True`` ``0`` stay,
``1`` up, ``2`` down (``action_size`` 3). An action is an integer scalar (a float or a non-scalar
raises ``ValueError`` when ``step`` is traced); one outside ``[0, action_size)`` does not move the
paddle either way: the step is not taken, the game ends as ``terminated`` with reward 0 and a zeroed
frame, and ``metrics["invalid_action"]`` is 1 (see ``jaxpg.envs.base``).

``FrameDifference`` turns the frames into the difference of consecutive frames, the
preprocessing of the seed: the policy then sees where things move.

README: *``pong`` is a Pong written for jaxpg in pure JAX (rendered 80x80 frames, a scripted
opponent with a speed limit, games to 21 points) so that thousands of games run in one ``vmap``;
it is not the Atari 2600 ROM, and its scores are not Atari scores.*
"""

from __future__ import annotations

import math
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from jaxpg.envs.base import Env, State
from jaxpg.envs.wrappers import Wrapper


@struct.dataclass
class PongData:
    """State of one game, in court units (the court is ``[0, 1] x [0, 1]``, ``y`` down).

    Attributes:
      ball: ``[2]`` ball centre ``(x, y)``.
      ball_vel: ``[2]`` ball velocity per step.
      paddles: ``[2]`` centre heights ``(agent, opponent)``.
      score: ``[2]`` int32 points ``(agent, opponent)``.
      rng: raw key data (``jax.random.key_data``) for the serves.
    """

    ball: jax.Array
    ball_vel: jax.Array
    paddles: jax.Array
    score: jax.Array
    rng: jax.Array


def _coverage(lo: jax.Array, hi: jax.Array, size: int) -> jax.Array:
    """``[size]`` fraction of each pixel ``[i / size, (i + 1) / size]`` covered by ``[lo, hi]``."""
    edges = jnp.arange(size + 1, dtype=jnp.float32) / size
    return jnp.clip(jnp.minimum(hi, edges[1:]) - jnp.maximum(lo, edges[:-1]), 0.0, None) * size


def _video_frame(image: np.ndarray, height: int = 240) -> np.ndarray:
    """``[size, size]`` values in ``[0, 1]`` as an ``[H, W, 3]`` uint8 grey image about ``height``
    pixels high (each pixel a square block)."""
    scale = max(1, height // image.shape[0])
    grey = (np.clip(image, 0.0, 1.0) * 255).astype(np.uint8).repeat(scale, axis=0).repeat(scale, axis=1)
    return np.stack([grey] * 3, axis=-1)


def _as_key(key: jax.Array) -> jax.Array:
    """A typed key from a typed key or a raw ``uint32`` one."""
    return key if jnp.issubdtype(key.dtype, jax.dtypes.prng_key) else jax.random.wrap_key_data(key)


class Pong(Env):
    """Pure-JAX two-paddle Pong against a scripted opponent; see the module docstring.

    Args:
      size: frames are ``size x size`` pixels (observation ``[size * size]``).
      stay_action: actions ``{stay, up, down}`` instead of ``{up, down}``.
      winning_score: points that end (terminate) a game.
      max_episode_steps: steps that truncate a game.
      paddle_height, paddle_width, ball_size: in court units (fractions of the court's side).
      paddle_speed, opponent_speed: largest paddle moves per step, in court units.
      ball_speed, max_ball_speed: the serve's speed and the cap, in court units per step.
      speedup: factor on the ball's speed at every paddle hit.
      max_bounce_angle, serve_angle: radians from the horizontal.
    """

    discrete = True
    task_score_name = "score_difference"
    # There is no physical time unit; videos play 50 steps a second (the ball crosses the court
    # in about a second at the serve's speed).
    dt = 1.0 / 50

    # Distance of each paddle's outer side from its edge of the court.
    paddle_margin = 0.05

    def __init__(
        self,
        size: int = 80,
        stay_action: bool = False,
        winning_score: int = 21,
        max_episode_steps: int = 20_000,
        paddle_height: float = 0.2,
        paddle_width: float = 0.025,
        ball_size: float = 0.025,
        paddle_speed: float = 0.04,
        opponent_speed: float = 0.015,
        ball_speed: float = 0.02,
        max_ball_speed: float = 0.06,
        speedup: float = 1.1,
        max_bounce_angle: float = math.pi / 3,
        serve_angle: float = math.pi / 6,
    ):
        if size < 8:
            raise ValueError(f"size must be >= 8, got {size}")
        if winning_score < 1:
            raise ValueError(f"winning_score must be >= 1, got {winning_score}")
        if not 0 < ball_speed <= max_ball_speed < 0.25:  # one reflection per step keeps the ball inside
            raise ValueError(f"need 0 < ball_speed <= max_ball_speed < 0.25, got {ball_speed}, {max_ball_speed}")
        self.size = size
        self.stay_action = stay_action
        self.action_size = 3 if stay_action else 2
        self.observation_size = size * size
        self.image_shape = (size, size, 1)
        self.winning_score = winning_score
        self.max_episode_steps = max_episode_steps
        self.paddle_height = paddle_height
        self.paddle_width = paddle_width
        self.ball_size = ball_size
        self.paddle_speed = paddle_speed
        self.opponent_speed = opponent_speed
        self.ball_speed = ball_speed
        self.max_ball_speed = max_ball_speed
        self.speedup = speedup
        self.max_bounce_angle = max_bounce_angle
        self.serve_angle = serve_angle
        # x of the paddles' front faces: the agent's (right) paddle faces left, the opponent's right.
        self.agent_face = 1.0 - self.paddle_margin - paddle_width
        self.opponent_face = self.paddle_margin + paddle_width

    # -- drawing ---------------------------------------------------------------------------------

    def _rect(self, cx: jax.Array, cy: jax.Array, w: float, h: float) -> jax.Array:
        """``[size, size]`` coverage image of the rectangle of centre ``(cx, cy)``, size ``w x h``."""
        rows = _coverage(cy - h / 2, cy + h / 2, self.size)
        cols = _coverage(cx - w / 2, cx + w / 2, self.size)
        return rows[:, None] * cols[None, :]

    def render(self, data: PongData) -> jax.Array:
        """``[size, size]`` float32 frame in ``[0, 1]`` of one game: ball and both paddles."""
        w, h = self.paddle_width, self.paddle_height
        agent = self._rect(jnp.asarray(self.agent_face + w / 2), data.paddles[0], w, h)
        opponent = self._rect(jnp.asarray(self.opponent_face - w / 2), data.paddles[1], w, h)
        ball = self._rect(data.ball[0], data.ball[1], self.ball_size, self.ball_size)
        return jnp.clip(agent + opponent + ball, 0.0, 1.0)

    def render_frame(self, obs: np.ndarray) -> np.ndarray:
        """Video frame ``[H, W, 3]`` uint8 of an observation ``[size * size]`` (on the host)."""
        return _video_frame(np.asarray(obs).reshape(self.size, self.size))

    def observe(self, data: PongData) -> jax.Array:
        """The observation ``[size * size]``: the flattened frame."""
        return self.render(data).reshape(-1)

    # -- physics ---------------------------------------------------------------------------------

    def serve(self, key: jax.Array) -> tuple[jax.Array, jax.Array]:
        """A serve from the centre line: ``(ball [2], ball_vel [2])``."""
        k_y, k_side, k_angle = jax.random.split(key, 3)
        y = jax.random.uniform(k_y, minval=0.25, maxval=0.75)
        side = jnp.where(jax.random.bernoulli(k_side), 1.0, -1.0)
        angle = jax.random.uniform(k_angle, minval=-self.serve_angle, maxval=self.serve_angle)
        ball = jnp.stack([jnp.asarray(0.5, jnp.float32), y])
        vel = self.ball_speed * jnp.stack([side * jnp.cos(angle), jnp.sin(angle)])
        return ball, vel.astype(jnp.float32)

    def _paddle_move(self, action: jax.Array) -> jax.Array:
        """``[]`` signed move of the agent's paddle (negative: up) for a discrete action."""
        direction = jnp.where(action == 0, -1.0, 1.0)  # {up, down}
        if self.stay_action:
            direction = jnp.where(action == 0, 0.0, jnp.where(action == 1, -1.0, 1.0))
        return self.paddle_speed * direction

    def _bounce(self, speed: jax.Array, offset: jax.Array, direction: float) -> jax.Array:
        """Velocity ``[2]`` leaving a paddle: faster by ``speedup``, angle set by the hit's
        ``offset`` in ``[-1, 1]`` from the paddle's centre, horizontally along ``direction``."""
        new_speed = jnp.minimum(speed * self.speedup, self.max_ball_speed)
        angle = jnp.clip(offset, -1.0, 1.0) * self.max_bounce_angle
        return new_speed * jnp.stack([direction * jnp.cos(angle), jnp.sin(angle)])

    def dynamics(self, data: PongData, action: jax.Array) -> tuple[PongData, jax.Array, jax.Array]:
        """One step of the game (module docstring). Returns ``(data, reward [], hit [])``:
        reward +1 / -1 for a point won / lost (0 otherwise), ``hit`` true where the agent's
        paddle returned the ball."""
        half_b = self.ball_size / 2
        half_h = self.paddle_height / 2
        lo, hi = half_h, 1.0 - half_h
        agent_y = jnp.clip(data.paddles[0] + self._paddle_move(action), lo, hi)
        gap = data.ball[1] - data.paddles[1]
        opp_y = jnp.clip(data.paddles[1] + jnp.clip(gap, -self.opponent_speed, self.opponent_speed), lo, hi)

        old_x = data.ball[0]
        x, y = data.ball[0] + data.ball_vel[0], data.ball[1] + data.ball_vel[1]
        vx, vy = data.ball_vel[0], data.ball_vel[1]
        # Walls: reflect about the line the ball's edge touches (one reflection: |vy| < 1 - ball).
        top, bottom = y < half_b, y > 1.0 - half_b
        y = jnp.where(top, 2 * half_b - y, jnp.where(bottom, 2 * (1.0 - half_b) - y, y))
        vy = jnp.where(top | bottom, -vy, vy)

        speed = jnp.sqrt(vx * vx + vy * vy)
        reach = half_h + half_b  # a hit: the ball's centre within this of the paddle's centre
        # Agent's paddle: the ball's right edge crosses the face this step, moving right.
        hit = (vx > 0) & (old_x + half_b <= self.agent_face) & (x + half_b > self.agent_face)
        hit = hit & (jnp.abs(y - agent_y) <= reach)
        agent_vel = self._bounce(speed, (y - agent_y) / reach, -1.0)
        # Opponent's paddle: the ball's left edge crosses the face, moving left.
        opp_hit = (vx < 0) & (old_x - half_b >= self.opponent_face) & (x - half_b < self.opponent_face)
        opp_hit = opp_hit & (jnp.abs(y - opp_y) <= reach)
        opp_vel = self._bounce(speed, (y - opp_y) / reach, 1.0)
        # Reflect the part of the move past the face back into the court.
        x = jnp.where(hit, 2 * (self.agent_face - half_b) - x, x)
        x = jnp.where(opp_hit, 2 * (self.opponent_face + half_b) - x, x)
        vel = jnp.where(hit, agent_vel, jnp.where(opp_hit, opp_vel, jnp.stack([vx, vy])))
        ball = jnp.stack([x, y])

        won = x - half_b < 0.0
        lost = x + half_b > 1.0
        point = won | lost
        rng, serve_key = jax.random.split(_as_key(data.rng))
        serve_ball, serve_vel = self.serve(serve_key)
        ball = jnp.where(point, serve_ball, ball)
        vel = jnp.where(point, serve_vel, vel)
        score = data.score + jnp.stack([won, lost]).astype(jnp.int32)
        reward = won.astype(jnp.float32) - lost.astype(jnp.float32)
        new = PongData(
            ball=ball.astype(jnp.float32),
            ball_vel=vel.astype(jnp.float32),
            paddles=jnp.stack([agent_y, opp_y]).astype(jnp.float32),
            score=score,
            rng=jax.random.key_data(rng),
        )
        return new, reward, hit

    # -- Env -------------------------------------------------------------------------------------

    def _metrics(self, data: PongData, hit: jax.Array) -> dict[str, jax.Array]:
        return {
            "task_score": (data.score[0] - data.score[1]).astype(jnp.float32),
            "hit": hit.astype(jnp.float32),
        }

    def _reset(self, key: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        serve_key, rng = jax.random.split(_as_key(key))
        ball, vel = self.serve(serve_key)
        data = PongData(
            ball=ball,
            ball_vel=vel,
            paddles=jnp.full((2,), 0.5, jnp.float32),
            score=jnp.zeros((2,), jnp.int32),
            rng=jax.random.key_data(rng),
        )
        return data, self.observe(data), self._metrics(data, jnp.zeros((), bool))

    def _step(self, state: State, action: jax.Array) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict]:
        data, reward, hit = self.dynamics(state.data, action)
        terminated = jnp.max(data.score) >= self.winning_score
        return data, self.observe(data), reward, terminated, self._metrics(data, hit)


class FrameDifference(Wrapper):
    """Observation = current frame minus the previous frame (``[obs]`` float32 in ``[-1, 1]``).

    The preprocessing of Karpathy's and MinPy's Pong from pixels: a single difference image
    shows where the ball and the paddles move, which one frame cannot. The previous frame rides
    in ``info["prev_frame"]``. After ``reset`` the observation is all zeros (there is no previous
    frame: the seed's ``np.zeros(D)``), or with ``first="frame"`` the first frame itself (the
    difference from an empty picture). Wrap the bare task (``EpisodeStats(FrameDifference(
    Pong()))``) so that ``AutoReset`` restarts the difference with the new game.
    """

    def __init__(self, env: Env, first: str = "zeros"):
        if first not in ("zeros", "frame"):
            raise ValueError(f"first must be 'zeros' or 'frame', got {first!r}")
        super().__init__(env)
        self.first = first

    def reset(self, key: jax.Array) -> State:
        state = self.env.reset(key)
        obs = jnp.zeros_like(state.obs) if self.first == "zeros" else state.obs
        return state.replace(obs=obs, info={**state.info, "prev_frame": state.obs})

    def render_frame(self, obs: np.ndarray) -> np.ndarray:
        """Video frame ``[H, W, 3]`` uint8 of a difference observation ``[size * size]``: what the
        policy sees, mid-grey where nothing changed, white where an object arrived, black where
        it left (a paddle that stands still does not show)."""
        height, width = self.image_shape[:2]
        return _video_frame(0.5 + 0.5 * np.asarray(obs).reshape(height, width))

    def step(self, state: State, action: jax.Array) -> State:
        stepped = self.env.step(state, action)
        frame = stepped.obs
        return stepped.replace(obs=frame - state.info["prev_frame"], info={**stepped.info, "prev_frame": frame})


class DifferencePong(FrameDifference):
    """The registered task ``pong``: ``Pong`` seen through ``FrameDifference``, the observation the
    seed's agents learn from (``jaxpg.envs.make("pong", size=40)``). ``pong_kwargs`` go to ``Pong``;
    ``first`` to ``FrameDifference``. ``unwrapped`` is the ``Pong`` that draws the frames."""

    # The class that ``**pong_kwargs`` construct: its options are this task's too
    # (``jaxpg.run.command.task_options.option_types``).
    OPTIONS_FORWARDED_TO = Pong

    def __init__(self, first: str = "zeros", **pong_kwargs: Any):
        super().__init__(Pong(**pong_kwargs), first=first)
