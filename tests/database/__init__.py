"""Tests of vfs.database (one file per module: tests/database/test_<module>.py)."""
