"""The modes of ``benchmarks/throughput.py``, one module each (``env``, ``train``, ``scaling``, ``learner``,
``evaluation`` for ``eval``, ``host``): each holds its measurement, its table and its command line
(``<mode>_main(argv)``). They import ``harness`` as the scripts do, so ``benchmarks/`` must be on
``sys.path`` (as it is when ``python benchmarks/throughput.py`` runs)."""
