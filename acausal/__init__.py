"""acausal: Modelica-style acausal component modelling in Python."""
