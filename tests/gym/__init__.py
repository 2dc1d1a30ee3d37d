"""Tests of vfs.gym (one file per module: tests/gym/test_<module>.py)."""
