"""Stage 1, the model: symbols, prescribed signals, the declarations a component makes, components and
``connect``, the connectors of the physical domains, the partial models the library shares, and what a component
class says about itself."""
