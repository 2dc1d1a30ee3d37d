"""Tests of vfs.interop (one file per module: tests/interop/test_<module>.py)."""
