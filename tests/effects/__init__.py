"""Tests of vfs.effects (one file per module: tests/effects/test_<module>.py)."""
