"""Tests of vfs; each folder mirrors the subpackage of vfs whose modules it tests."""
