"""The host process: several processes, profiling, the compilation cache, memory, provenance."""
