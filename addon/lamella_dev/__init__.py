"""Lamella's development package: what measures and documents the extension but does not ship in it
(the stochastic reference, the accuracy suite, metrics, benchmarks, plots, the canonical render
scenes, the table generators, the reference pages). It imports ``lamella``; ``lamella`` never
imports it (a test checks), so the extension zip leaves it out whole."""
