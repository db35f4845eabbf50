"""A run's outputs behind one ``Sink`` protocol: ``metrics.jsonl``, TensorBoard, the console, the
curves and videos (``sinks`` lists those a run opens)."""
