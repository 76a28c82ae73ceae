"""Peers from other libraries, as vpid-bench optimizers: the optimizers an engineer would reach
for besides the paper's DE variants.

* ``optimizer=cmaes``: CMA-ES from the ``cma`` package (:mod:`vpid_peers.cmaes`);
* ``optimizer=nevergrad``: any optimizer of nevergrad's registry
  (:mod:`vpid_peers.nevergrad_opt`).

Both libraries are an extra (``pip install 'vpid-bench[peers]'``). Nothing here imports them
at import time: an optimizer is registered only when its library can be found, and the library
is imported when the optimizer is built.
"""
