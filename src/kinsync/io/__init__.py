"""Readers and writers: files in, plain containers out (and back)."""
