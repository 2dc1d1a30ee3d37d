"""Tests of vfs.scenarios (one file per module: tests/scenarios/test_<module>.py)."""
