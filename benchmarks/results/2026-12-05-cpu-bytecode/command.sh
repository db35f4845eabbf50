# 2 CPU cores (AMD EPYC), Python 3.11.7, MuJoCo 3.17.0, warp-lang 1.19.0, 2026-12-05. Does `import mujoco.mjx`
# pay for compiling its Python sources to bytecode when they were installed without it? The GPU recipe
# installs MuJoCo, MJX and warp-lang with `pip install --no-compile --target /tmp/site`, and this machine
# sets PYTHONDONTWRITEBYTECODE=1, under which no process ever writes the bytecode: each import compiles the
# sources again. A copy of the venv's mujoco/ and warp/ without __pycache__ stands for such an install.
SP=$(python -c "import site; print(site.getsitepackages()[0])")
rm -rf /tmp/pyc && mkdir -p /tmp/pyc && cp -r $SP/mujoco $SP/warp /tmp/pyc/
find /tmp/pyc -name __pycache__ -type d -exec rm -rf {} +
echo "no bytecode, PYTHONDONTWRITEBYTECODE=1 (each process compiles the sources):"
for i in 1 2 3; do PYTHONDONTWRITEBYTECODE=1 PYTHONPATH=/tmp/pyc python import_mjx.py; done
echo "the same, then python -m compileall (as pip install does without --no-compile):"
python -m compileall -q /tmp/pyc
for i in 1 2 3; do PYTHONDONTWRITEBYTECODE=1 PYTHONPATH=/tmp/pyc python import_mjx.py; done
# Ran as above (import_mjx.log): without bytecode 2.98-3.19 s, with it 1.93-2.36 s; about 0.8 s of each import.

# The one-off Python this ran (import_mjx.py ) left the tree when results/ became records and commands only;
# it is at commit 20ac6f2: git show 20ac6f2:benchmarks/results/2026-12-05-cpu-bytecode/NAME.py
