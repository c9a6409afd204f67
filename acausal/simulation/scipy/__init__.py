"""The scipy backend's segment integration: scipy's integrators stepped with state events, the energy integrals
carried as extra states, and what a failed run says."""
