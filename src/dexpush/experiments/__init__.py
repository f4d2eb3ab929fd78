"""Experiments: the benchmark scenarios, methods, the episode runner, the batched simulator,
records, the resumable benchmark and its tables."""
