"""The modes of ``benchmarks/time_to_return.py``, one module each (``run``, ``sweep``, ``plot``): each
holds its measurement, its table and its command line (``<mode>_main(argv)``). They import ``harness``
as the scripts do, so ``benchmarks/`` must be on ``sys.path`` (as it is when
``python benchmarks/time_to_return.py`` runs)."""
