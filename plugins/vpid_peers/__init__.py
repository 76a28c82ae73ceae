"""The optimizers an engineer would reach for besides the paper's DE variants: ``scipy_de``,
``lsq``, ``de_lsq``, ``cmaes`` and ``nevergrad`` (docs/peers.md, docs/optimizers.md); the last
two need the ``peers`` extra (``pip install 'vpid-bench[peers]'``).
"""
