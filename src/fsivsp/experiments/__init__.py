"""What fsivsp measures against exact or physical solutions: convergence studies in space and time (`study`) in
the paper's norms (`norms`, `projection`), the paper's experiment (`paper`) and its tables (`report`), the
verification matrix (`verification`) and the Moens–Korteweg wave speed (`moens_korteweg`)."""
