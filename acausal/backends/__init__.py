"""Stage 3, the backends: the lowered program printed as numpy code (:mod:`.numpy`), translated to CasADi
expressions (:mod:`.casadi`), and the machine's C compiler for the code printed as C (:mod:`.ccompiler`)."""
