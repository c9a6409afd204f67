"""Helpers every report shares: CSV and markdown tables (:mod:`.tables`), Sankey diagrams (:mod:`.sankey`)."""
