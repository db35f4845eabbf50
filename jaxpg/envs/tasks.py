"""Every task jaxpg knows, declared in one place before any task module is imported: the class
that implements it and, for a task that reproduces a Gymnasium env, that env's id, its step limit
and its ``info`` keys. Nothing here imports MuJoCo, MJX or Gymnasium: ``jaxpg.envs`` and the
Gymnasium ids' registration (``jaxpg.envs.gymnasium_api``) read these tables at import.

A new task is one ``Task`` in ``TASKS`` (or ``register(name, Task(...))`` from outside):

    register("slider", Task("my_package.slider:Slider"))
"""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Task:
    """What jaxpg knows of a task without importing it.

    Attributes:
      target: ``"module:Class"`` of the task's class, imported on first use.
      gymnasium_id: the id of the Gymnasium env it reproduces (``"Hopper-v5"``), or ``None``.
      gymnasium_limit: Gymnasium's step limit for that env.
      reset_info: the keys of Gymnasium v5's ``info`` after ``reset``.
      step_info: the keys of Gymnasium v5's ``info`` after ``step``.
    """

    target: str
    gymnasium_id: str | None = None
    gymnasium_limit: int | None = None
    reset_info: tuple[str, ...] = ()
    step_info: tuple[str, ...] = ()


_POSITION = ("x_position", "z_distance_from_origin")
_PLANAR = ("x_position", "y_position", "distance_from_origin")
_TENDONS = ("tendon_length", "tendon_velocity")
_STANDUP = ("x_position", "y_position", "z_distance_from_origin")
_LOCOMOTION = ("x_velocity", "reward_forward", "reward_ctrl", "reward_survive")


TASKS: dict[str, Task] = {
    "hopper": Task("jaxpg.envs.hopper:Hopper", "Hopper-v5", 1000, _POSITION, (*_POSITION, *_LOCOMOTION)),
    "inverted_pendulum": Task(
        "jaxpg.envs.inverted_pendulum:InvertedPendulum", "InvertedPendulum-v5", 1000, (), ("reward_survive",)
    ),
    "inverted_double_pendulum": Task(
        "jaxpg.envs.inverted_double_pendulum:InvertedDoublePendulum",
        "InvertedDoublePendulum-v5",
        1000,
        (),
        ("reward_survive", "distance_penalty", "velocity_penalty"),
    ),
    "half_cheetah": Task(
        "jaxpg.envs.half_cheetah:HalfCheetah",
        "HalfCheetah-v5",
        1000,
        ("x_position",),
        ("x_position", "x_velocity", "reward_forward", "reward_ctrl"),
    ),
    "swimmer": Task(
        "jaxpg.envs.swimmer:Swimmer",
        "Swimmer-v5",
        1000,
        _PLANAR,
        (*_PLANAR, "x_velocity", "y_velocity", "reward_forward", "reward_ctrl"),
    ),
    "pusher": Task("jaxpg.envs.pusher:Pusher", "Pusher-v5", 100, (), ("reward_dist", "reward_ctrl", "reward_near")),
    "walker2d": Task("jaxpg.envs.walker2d:Walker2d", "Walker2d-v5", 1000, _POSITION, (*_POSITION, *_LOCOMOTION)),
    "humanoid": Task(
        "jaxpg.envs.humanoid:Humanoid",
        "Humanoid-v5",
        1000,
        (*_PLANAR, *_TENDONS),
        (*_PLANAR, *_TENDONS, "x_velocity", "y_velocity")
        + ("reward_forward", "reward_ctrl", "reward_contact", "reward_survive"),
    ),
    "humanoid_standup": Task(
        "jaxpg.envs.humanoid_standup:HumanoidStandup",
        "HumanoidStandup-v5",
        1000,
        (*_STANDUP, *_TENDONS),
        (*_STANDUP, *_TENDONS, "reward_linup", "reward_quadctrl", "reward_impact"),
    ),
    "reacher": Task("jaxpg.envs.reacher:Reacher", "Reacher-v5", 50, (), ("reward_dist", "reward_ctrl")),
    "ant": Task(
        "jaxpg.envs.ant:Ant",
        "Ant-v5",
        1000,
        _PLANAR,
        (*_PLANAR, "x_velocity", "y_velocity", "reward_forward", "reward_ctrl", "reward_contact", "reward_survive"),
    ),
    "cartpole": Task("jaxpg.envs.cartpole:CartPole", "CartPole-v1", 500),
    # jaxpg's own Pong, observed as frame differences (jaxpg.envs.pong.DifferencePong).
    "pong": Task("jaxpg.envs.pong:DifferencePong"),
    # The Atari ROM through the Arcade Learning Environment (needs `pip install 'jaxpg[atari]'`).
    "atari_pong": Task("jaxpg.envs.atari:AtariPong"),
}


# Views of TASKS that the rest of jaxpg reads (``register`` keeps them in step):
# name -> "module:Class";
REGISTRY: dict[str, str] = {}
# task -> (the id of the Gymnasium env it reproduces, Gymnasium's step limit for that env):
# ``python -m jaxpg.evaluate --gymnasium`` replays a policy in that env (``jaxpg.run.evaluation.replay``),
# and ``jaxpg.envs.gymnasium_api`` registers the task as ``jaxpg/<id>``;
GYMNASIUM_COUNTERPARTS: dict[str, tuple[str, int]] = {}
# task -> (keys of ``info`` after ``reset``, keys of ``info`` after ``step``), for the tasks above.
INFO_KEYS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {}


def register(name: str, task: Task) -> None:
    """Declare ``task`` as ``name`` (replacing a task of that name) in ``TASKS`` and its views."""
    TASKS[name] = task
    REGISTRY[name] = task.target
    if task.gymnasium_id is not None:
        GYMNASIUM_COUNTERPARTS[name] = (task.gymnasium_id, int(task.gymnasium_limit or 0))
        INFO_KEYS[name] = (tuple(task.reset_info), tuple(task.step_info))
    else:
        GYMNASIUM_COUNTERPARTS.pop(name, None)
        INFO_KEYS.pop(name, None)


def unregister(name: str) -> None:
    """Forget the task ``name`` (a no-op for an unknown one)."""
    for table in (TASKS, REGISTRY, GYMNASIUM_COUNTERPARTS, INFO_KEYS):
        table.pop(name, None)


for _name, _task in list(TASKS.items()):
    register(_name, _task)
