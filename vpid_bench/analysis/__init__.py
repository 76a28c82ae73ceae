"""What a record allows, computed by the job (never by the report, which only reads files):

* :mod:`.optimum`: each instance's attainable optimum, by a deterministic local polish;
* :mod:`.identifiability`: Cramér–Rao bounds of the parameters from the Fisher information;
* :mod:`.intervals` and :mod:`.estimates`: without a truth, 95 % intervals of an identified
  vector (Jacobian, σ estimated from the residuals; the profile likelihood) and a problem's
  fixed comparison rows.

All need a problem that offers residual vectors; the bounds and floors need its true
parameters, the intervals are for a problem without them.
"""
