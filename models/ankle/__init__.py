"""The CYBERLEGs ankle actuator of the paper: the model (:mod:`.actuator`), named parameter sets
(:mod:`.presets`), the moment-arm planning (:mod:`.planning`), the bench protocol (:mod:`.protocol`) and the
paper's report (:mod:`.paper`)."""
