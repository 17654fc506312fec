"""Fuzzing of the file readers (issue 21): see harness.py."""
