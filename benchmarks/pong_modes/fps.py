"""``benchmarks/pong.py --fps-envs``: jaxpg Pong's env and one A2C training iteration, frames per second."""

from __future__ import annotations

from typing import Any

import harness
import jax
import jax.numpy as jnp

from jaxpg import algos, envs


def a2c_config(num_envs: int) -> Any:
    """``a2c.Config`` of A2C on Pong (``a2c.PRESETS["pong"]``) with ``num_envs`` games."""
    return algos.get("a2c").Config(**algos.preset("a2c", "pong", "pong"), num_envs=num_envs)


# ---------------------------------------------------------------------------------------------
# fps: the env and one training iteration, timed after compilation.


def env_fps(num_envs: int, horizon: int, size: int, repeats: int = 3) -> dict:
    """Frames/s of ``num_envs`` games stepped with random actions (auto-reset included)."""
    from jaxpg import rollout as rollout_lib

    env = envs.AutoReset(envs.make_shared("pong", size=size))
    state = rollout_lib.reset_batch(env, jax.random.PRNGKey(0), num_envs)

    def random_act(params, obs, key):  # noqa: ANN001, ANN202
        del params
        return jax.random.randint(key, obs.shape[:1], 0, env.action_size), jnp.zeros(obs.shape[0])

    run = jax.jit(lambda s, k: rollout_lib.rollout(env, random_act, None, s, k, horizon)[0])
    chain = [state]

    def call(i: int) -> Any:  # each call continues from the last one's games
        chain.append(run(chain[-1], jax.random.PRNGKey(1 + i)))
        return chain[-1]

    compile_s, seconds, _ = harness.time_calls(call, repeats)
    return {"fps": num_envs * horizon / seconds, "compile_s": compile_s}


def train_fps(num_envs: int, size: int, per_call: int = 1, iterations: int = 24) -> dict:
    """Frames/s of A2C training iterations (sampling + update), ``per_call`` iterations per compiled
    call (a ``lax.scan``), calls dispatched without waiting."""
    from jaxpg import train as train_lib

    a2c = algos.get("a2c")
    config = a2c_config(num_envs)
    ts = train_lib.own_buffers(a2c.init(jax.random.PRNGKey(0), envs.make_shared("pong", size=size), config))
    step = train_lib.compiled_block(a2c.update, per_call, False)
    compile_s, seconds, _ = harness.time_back_to_back(step, ts, max(1, iterations // per_call))
    return {
        "fps": config.samples_per_iteration * per_call / seconds,
        "compile_s": compile_s,
        "iterations_per_call": per_call,
    }
