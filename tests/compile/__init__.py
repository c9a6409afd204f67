"""Tests of the compiler's stages (acausal.compile), one stage at a time."""
