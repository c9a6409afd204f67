"""Tests of regressions."""
