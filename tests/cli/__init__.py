"""Tests of vfs.cli (one file per module: tests/cli/test_<module>.py)."""
