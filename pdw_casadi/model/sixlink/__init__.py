"""Parts of the 6-link walker besides its feet: the leg chain (:mod:`.chain`), the knees
(:mod:`.knees`) and the Poincare section (:mod:`.section`). The walker
(:mod:`pdw_casadi.model.walkers.humanlike_6link`) assembles them with a foot
(:mod:`pdw_casadi.model.feet`) into phases and transitions."""
