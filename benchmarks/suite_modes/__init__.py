"""The modes of ``benchmarks/suite.py``, one module each (``run``, ``plot``, ``count``, ``physics``), and
``verdicts``: the targets a setting's seeds are judged against. Each mode module holds its
measurement, its table and its command line (``<mode>_main(argv)``). They import ``harness`` as the
scripts do, so ``benchmarks/`` must be on ``sys.path`` (as it is when ``python benchmarks/suite.py``
runs)."""
