"""The ride models of the vehicle suite: one simulation core for every linear mechanical
system (:mod:`.linear`), road inputs (:mod:`.roads`) and the models built on them
(:mod:`.quarter`: the quarter car). A new linear model is matrices, not a new kernel."""
