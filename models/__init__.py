"""Assembled models (imported as ``acausal.models``)."""
