"""The command line: flags, the flags read first, planning a run into a ``Plan``, startup, ``main``."""
