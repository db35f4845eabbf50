"""A Gymnasium env in a process of its own, for ``AsyncVectorEnv``'s default ``fork`` context.

JAX deadlocks in a process forked after JAX started its threads. ``os.fork`` hooks note whether that
happened (``forked_after_jax``); ``gymnasium_api.JaxpgEnv`` then runs in a fresh interpreter
(``Worker``, no fork) and forwards every call to it through two pipes.
"""

from __future__ import annotations

import os
import subprocess
import sys
from typing import Any

# ----- JAX and fork: a single env made in a process forked after JAX started runs elsewhere -----

_jax_started_before_fork = False
_forked_after_jax = False


def _jax_started() -> bool:
    """JAX has started a backend (and its threads) in this process."""
    try:
        from jax._src import xla_bridge

        return bool(xla_bridge._backends)
    except (ImportError, AttributeError):  # pragma: no cover - a JAX without the private table
        return True


def _before_fork() -> None:
    """``os.fork`` hook in the parent: note whether JAX is running."""
    global _jax_started_before_fork
    _jax_started_before_fork = _jax_started()


def _after_fork_in_child() -> None:
    """``os.fork`` hook in the child: JAX cannot run here if it ran in the parent (nor in its parents)."""
    global _forked_after_jax
    _forked_after_jax = _forked_after_jax or _jax_started_before_fork


def forked_after_jax() -> bool:
    """This process was forked (directly or through its parents) after JAX started in its parent."""
    return _forked_after_jax


os.register_at_fork(before=_before_fork, after_in_child=_after_fork_in_child)


class Worker:
    """A ``gymnasium_api.JaxpgEnv`` in a fresh Python process (no fork: a new interpreter), driven through two
    pipes; ``call(name, *args, **kwargs)`` runs ``env.name(...)`` there and returns its result or
    raises its exception."""

    def __init__(self, env_kwargs: dict[str, Any]):
        from multiprocessing.connection import Connection

        to_worker_r, to_worker_w = os.pipe()
        from_worker_r, from_worker_w = os.pipe()
        code = f"from jaxpg.envs.gymnasium_api import serve; serve({to_worker_r}, {from_worker_w})"
        path = os.pathsep.join([p for p in sys.path if p] + [os.environ.get("PYTHONPATH", "")])
        self.process = subprocess.Popen(
            [sys.executable, "-c", code],
            pass_fds=(to_worker_r, from_worker_w),
            env={**os.environ, "PYTHONPATH": path},
        )
        os.close(to_worker_r)
        os.close(from_worker_w)
        self._send = Connection(to_worker_w, readable=False)
        self._recv = Connection(from_worker_r, writable=False)
        self.spaces = self._result(env_kwargs)

    def _result(self, message: Any) -> Any:
        try:
            self._send.send(message)
            ok, value = self._recv.recv()
        except (EOFError, OSError):
            code = self.process.wait(timeout=30)
            raise RuntimeError(f"jaxpg's env worker process exited with code {code} (its error is above)") from None
        if not ok:
            raise value
        return value

    def call(self, name: str, *args: Any, **kwargs: Any) -> Any:
        return self._result((name, args, kwargs))

    def close(self) -> None:
        if self.process.poll() is None:
            try:
                self.call("close")
            except RuntimeError:
                pass
            self.process.wait(timeout=30)
        self._send.close()
        self._recv.close()
