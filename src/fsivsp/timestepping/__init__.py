"""The fully discrete scheme (5.1) and its second-order variants: `Scheme` (`scheme`: the step matrix and its
solver built once, `step`), the time schemes' coefficients (`schemes`), the initial state (22)–(26)
(`initial`) and the time loop with its overlapping thread (`marching`). Imports `solvers` and the layers below."""
