"""Benchmarks and stored references (pure numpy + the stochastic reference; no bpy)."""
