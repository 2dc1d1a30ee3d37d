"""Tests of vfs.uncertainty (one file per module: tests/uncertainty/test_<module>.py)."""
