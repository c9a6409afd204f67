"""Alternative drive trains built from the same parts as the paper's actuator, the registry of every model the
protocol runs (:mod:`.registry`) and ``acausal compare`` (:mod:`.compare`)."""
