"""Tests of vfs.analysis (one file per module: tests/analysis/test_<module>.py)."""
