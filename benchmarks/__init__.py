"""Benchmarks of mpeg4fba; ``benchmarks.generate`` makes deterministic test scenes."""
