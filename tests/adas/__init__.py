"""Tests of vfs.adas (one file per module: tests/adas/test_<module>.py)."""
