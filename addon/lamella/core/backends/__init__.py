"""Backends that run the one model: numpy (arrays), trace (expression graph; base of OSL/nodes)."""
