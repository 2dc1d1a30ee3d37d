"""Tests of vfs.physics (one file per module: tests/physics/test_<module>.py)."""
