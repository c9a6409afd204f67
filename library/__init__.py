"""Component library of acausal (imported as ``acausal.library``)."""
