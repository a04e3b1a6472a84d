"""Magnetic soft robots on PyElastica."""
