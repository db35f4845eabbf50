"""The package's shape: every module imports alone, no module imports itself back, no file is long.

The graph is read from the source (``ast``), function-level imports included, so that an import
moved into a function to hide a circle still counts. ``from jaxpg.a import b`` is an edge to the
module ``jaxpg.a.b`` when that is a module, else to ``jaxpg.a``.
"""

import ast
import subprocess
import sys
from pathlib import Path

import jaxpg

PACKAGE_DIR = Path(jaxpg.__file__).parent


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE_DIR.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in sorted(PACKAGE_DIR.rglob("*.py"))}
# Modules of an optional extra -> the package they import at their top (skipped where it is missing).
OPTIONAL_MODULES = {"jaxpg.envs.brax_env": "brax"}


def imported_modules(path: Path) -> set[str]:
    """The jaxpg modules that the file at ``path`` imports anywhere in its source."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split(".")[0] == "jaxpg"}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module.split(".")[0] != "jaxpg":
                continue
            for alias in node.names:
                sub = f"{node.module}.{alias.name}"
                found.add(sub if sub in MODULES else node.module)
    return {name for name in found if name in MODULES}


def is_ancestor(package: str, module: str) -> bool:
    return module.startswith(package + ".")


def import_graph() -> dict[str, set[str]]:
    """Module -> the jaxpg modules it imports, less its own packages: Python runs a package's
    ``__init__`` before any module in it, so a module reading its own package (``jaxpg.envs.X``
    calling ``jaxpg.envs.make``) cannot meet a half-initialised module."""
    return {
        name: {m for m in imported_modules(path) if m != name and not is_ancestor(m, name)}
        for name, path in MODULES.items()
    }


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import circle of ``graph`` as a list of modules (first == last), or ``None``."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return path[path.index(nxt) :] + [nxt]
            if nxt not in state and (cycle := visit(nxt)):
                return cycle
        path.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)):
            return cycle
    return None


def test_find_cycle_finds_one():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    # The circle jaxpg had: the core's package imported sampling, which imported a module that
    # imported the core's package back (inside a function).
    graph = {"p": {"p.s"}, "p.s": {"m"}, "m": {"p"}}
    assert find_cycle(graph) == ["m", "p", "p.s", "m"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_the_graph_sees_function_level_imports():
    graph = import_graph()
    assert "jaxpg.algos.core" in graph["jaxpg.algos.npg"]
    assert "jaxpg.run.checkpoints.policy_io" in graph["jaxpg"]  # ``jaxpg.load_policy`` imports it when first used


def test_no_import_circle():
    assert find_cycle(import_graph()) is None


def test_the_device_mesh_knows_nothing_of_the_host():
    """``jaxpg.mesh`` is used inside jit; launching processes is ``jaxpg.run.host.processes``'s job."""
    assert import_graph()["jaxpg.mesh"] == set()
    assert not any(name.startswith("jaxpg.run") for name in import_graph()["jaxpg.algos.core.sampling"])


def test_every_module_imports_alone_in_a_fresh_interpreter():
    """Each module imported first, with no other jaxpg module loaded before it (one interpreter;
    the jaxpg modules are dropped from ``sys.modules`` between imports)."""
    script = (
        "import importlib, importlib.util, sys\n"
        "failed = []\n"
        f"for name in {sorted(MODULES)!r}:\n"
        "    for loaded in [m for m in sys.modules if m == 'jaxpg' or m.startswith('jaxpg.')]:\n"
        "        del sys.modules[loaded]\n"
        f"    if importlib.util.find_spec({OPTIONAL_MODULES!r}.get(name, 'jaxpg')) is None:\n"
        "        continue\n"
        "    try:\n"
        "        importlib.import_module(name)\n"
        "    except Exception as e:\n"
        "        failed.append(f'{name}: {type(e).__name__}: {e}')\n"
        "print('\\n'.join(failed))\n"
        "sys.exit(1 if failed else 0)\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr


def imported_in_a_fresh_interpreter(modules: str, check: str) -> str:
    """What ``check`` (a Python expression) prints after ``import {modules}`` in a new interpreter."""
    script = f"import sys\nimport {modules}\nprint({check})\n"
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


def test_the_command_lines_import_no_simulator_plots_or_checkpoints_and_touch_no_device():
    """Why some imports of ``jaxpg.run`` wait inside functions: importing the command lines
    leaves MuJoCo unimported (``startup.start`` chooses its GL backend first), JAX's devices
    untouched (``jax.distributed.initialize`` must come first), and matplotlib, Orbax and the
    optional Gymnasium out of ``--help``; the plotting command imports no JAX at all."""
    heavy = "[m for m in ('mujoco', 'matplotlib', 'orbax.checkpoint', 'gymnasium') if m in sys.modules]"
    started = "jax._src.xla_bridge.backends_are_initialized()"  # JAX's own test of it
    modules = "jaxpg.cli, jaxpg.evaluate, jax._src.xla_bridge"
    assert imported_in_a_fresh_interpreter(modules, f"{heavy}, {started}") == "[] False"
    assert imported_in_a_fresh_interpreter("jaxpg.run.outputs.plotting", "'jax' in sys.modules") == "False"


def test_tasks_without_mujoco_import_none():
    """CartPole and Pong, made with a batch as the command lines make them, leave MuJoCo (with MJX
    and MuJoCo Warp: seconds to import) unimported: ``envs.is_mjx`` tells an MJX task from another
    without importing MJX, and ``envs.warp_capacity`` asks it. An MJX task is one."""
    made = "[envs.make(name, batch=16) is not None for name in ('cartpole', 'pong')]"
    asked = "[envs.is_mjx(name) for name in ('cartpole', 'pong')], envs.warp_capacity('pong', {}, 16)"
    check = f"{made}, {asked}, 'mujoco' in sys.modules, envs.is_mjx('hopper')"
    assert imported_in_a_fresh_interpreter("jaxpg.envs as envs", check) == "[True, True] [False, False] {} False True"


def test_the_core_never_imports_brax_or_playground():
    """Brax and MuJoCo Playground are optional extras: the package, its command lines, its trainer and
    a task made by name leave both unimported, and only ``jaxpg.envs`` (inside ``task_class``, for a
    name with a colon) reaches the module that resolves their names."""
    modules = "jaxpg, jaxpg.envs as envs, jaxpg.cli, jaxpg.train, jaxpg.algos, jaxpg.evaluate"
    check = "envs.make('cartpole') is not None, [m for m in ('brax', 'mujoco_playground') if m in sys.modules]"
    assert imported_in_a_fresh_interpreter(modules, check) == "True []"
    graph = import_graph()
    importers = {name for name, imported in graph.items() if imported & {"jaxpg.envs.brax_task", "jaxpg.envs.brax_env"}}
    assert importers <= {"jaxpg.envs", "jaxpg.envs.brax_env", "jaxpg.envs.brax_task"}, importers


MAX_LINES = 400


def test_no_package_file_is_over_400_lines():
    """One job per file: a file that outgrows 400 lines does several and is split."""
    long = {name: n for name, path in MODULES.items() if (n := len(path.read_text().splitlines())) > MAX_LINES}
    assert not long, long


def top_level_names(path: Path) -> set[str]:
    """The names a module defines or imports at its top level."""
    names = set()
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.FunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.Assign):
            names |= {t.id for t in node.targets if isinstance(t, ast.Name)}
        elif isinstance(node, ast.ImportFrom | ast.Import):
            names |= {a.asname or a.name.split(".")[0] for a in node.names}
    return names


def test_no_local_name_hides_a_host_module():
    """A function whose argument or variable is named like a ``jaxpg.run`` module (``overwrite``,
    ``flags``) cannot reach that module: ``overwrite.exists_message`` on a bool is an
    ``AttributeError`` only when that line runs."""
    run_modules = {name.rsplit(".", 1)[1]: MODULES[name] for name in MODULES if name.startswith("jaxpg.run.")}
    exported = {name: top_level_names(path) for name, path in run_modules.items()}
    hidden = []
    for module, path in MODULES.items():
        for fn in ast.walk(ast.parse(path.read_text())):
            if not isinstance(fn, ast.FunctionDef):
                continue
            bound = {a.arg for a in fn.args.args + fn.args.kwonlyargs}
            bound |= {n.id for n in ast.walk(fn) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)}
            for node in ast.walk(fn):
                if (
                    isinstance(node, ast.Attribute)
                    and isinstance(node.value, ast.Name)
                    and node.value.id in bound
                    and node.attr in exported.get(node.value.id, ())
                ):
                    hidden.append(f"{module}.{fn.name}: {node.value.id}.{node.attr}")
    assert not hidden, hidden
