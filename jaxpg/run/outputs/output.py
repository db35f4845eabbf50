"""What a run prints and hands around on process 0 alone (``jaxpg.run.host.processes.is_primary``),
and one seed's slice of a state trained with several."""

from __future__ import annotations

from typing import Any

import jax

from jaxpg.run.host import processes
from jaxpg.run.outputs.sink import Block, Sink


def seed_slice(tree: Any, index: int, vmap_seeds: bool) -> Any:
    return jax.tree.map(lambda x: x[index], tree) if vmap_seeds else tree


def is_primary() -> bool:
    """This process writes files and prints (``jaxpg.run.host.processes.is_primary``)."""
    return processes.is_primary()


def show(line: str) -> None:
    if is_primary():
        print(line, flush=True)


class Silent(Sink):
    """The progress of the processes other than 0, which print nothing (and have no other sink)."""

    def write_block(self, block: Block) -> None:
        pass

    def write(self, *args: Any) -> None:
        pass

    def add_text(self, *args: Any) -> None:
        pass

    def update(self, *args: Any) -> None:
        pass

    def close(self) -> None:
        pass
