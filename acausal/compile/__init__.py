"""Stage 2, the compiler: a built model flattened, aliases eliminated, time events found, balanced, index-reduced,
sorted into blocks (BLT), solved, and lowered to one backend-neutral program (:mod:`.pipeline` runs them in
order); the energy accounts found by convention; looking into what was compiled."""
