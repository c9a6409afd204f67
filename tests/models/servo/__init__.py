"""Tests of models/servo."""
