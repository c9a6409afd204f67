"""Stage 4, the results: a run's :class:`~.result.Result` (its samples, dense output and energy integrals), the
interpolants between samples (:mod:`.interpolants`), the energy balance and chain found by convention
(:mod:`.energy`, :mod:`.run_balance`), the trust checks a result must pass (:mod:`.trust`, :mod:`.finite`), and its
views: plots, the HTML page, the Sankey diagram, files written atomically."""
