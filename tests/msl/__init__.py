"""Tests of msl."""
