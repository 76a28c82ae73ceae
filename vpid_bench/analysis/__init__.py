"""What a record allows, computed by the job (never by the report, which only reads files):

* :mod:`.optimum`: each instance's attainable optimum, by a deterministic local polish;
* :mod:`.identifiability`: Cramér–Rao bounds of the parameters from the Fisher information.

Both need a problem that offers residual vectors and knows its true parameters.
"""
