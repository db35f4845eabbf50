"""Build hooks beside pyproject.toml: every install of jaxpg, regular or editable, puts the start-up
file of its Gymnasium ids (``jaxpg-gymnasium-ids.pth``) into site-packages, so that
``gymnasium.make("jaxpg/Hopper-v5")`` works in a script that never imports jaxpg (Gymnasium 1.x
reads no plugin entry points). What the file does: ``jaxpg/envs/gymnasium_registration.py``, which
this script loads on its own (it imports nothing of jaxpg). ``python -m
jaxpg.envs.gymnasium_registration uninstall`` removes the file; ``pip uninstall jaxpg`` does too.
"""

import importlib.util
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py
from setuptools.command.editable_wheel import editable_wheel

HERE = Path(__file__).resolve().parent


def registration_module():  # noqa: ANN201 - a module object, loaded by path
    """``jaxpg/envs/gymnasium_registration.py`` as a module of its own (jaxpg's package unimported)."""
    spec = importlib.util.spec_from_file_location(
        "_jaxpg_build_registration", HERE / "jaxpg" / "envs" / "gymnasium_registration.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def write_pth(directory: Path) -> Path:
    """Write the start-up file into ``directory`` (a wheel's root); returns its path."""
    module = registration_module()
    return module.install(Path(directory))


class BuildPyWithIds(build_py):
    """``build_py`` that also puts the start-up file at the root of the built tree (regular wheels)."""

    def run(self) -> None:
        super().run()
        write_pth(Path(self.build_lib))

    def get_outputs(self, include_bytecode: bool = True) -> list[str]:
        name = registration_module().PTH_NAME
        return [*super().get_outputs(include_bytecode), str(Path(self.build_lib) / name)]


class EditableWheelWithIds(editable_wheel):
    """``editable_wheel`` that also puts the start-up file at the root of the editable wheel: the
    folder it hands to ``_install_namespaces`` is the one whose files the wheel holds. Where a
    setuptools release renames that step, the editable install goes on without the file (the
    ``install`` command above still writes it)."""

    def _install_namespaces(self, installation_dir: str, pth_prefix: str) -> None:
        super()._install_namespaces(installation_dir, pth_prefix)
        write_pth(Path(installation_dir))


setup(cmdclass={"build_py": BuildPyWithIds, "editable_wheel": EditableWheelWithIds})
