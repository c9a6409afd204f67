"""Tests of models/ankle."""
