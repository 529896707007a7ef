"""Benchmarks against the systems users would otherwise pick (MuJoCo, Gymnasium CartPole)."""
