"""Tests of models/bench."""
