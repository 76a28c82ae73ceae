"""vpid-bench's first-party peers of the paper's DE variants: the optimizers an engineer would
reach for besides them (see docs/peers.md and docs/optimizers.md).

* ``optimizer=scipy_de``: scipy's differential evolution (:mod:`vpid_peers.scipy_de`);
* ``optimizer=lsq``: multistart least squares on the residuals, IRLS for a sum of norms;
* ``optimizer=de_lsq``: DE4, then least squares from its best vector;
* ``optimizer=cmaes``: CMA-ES from the ``cma`` package (:mod:`vpid_peers.cmaes`);
* ``optimizer=nevergrad``: any optimizer of nevergrad's registry
  (:mod:`vpid_peers.nevergrad_opt`).

``cma`` and ``nevergrad`` are an extra (``pip install 'vpid-bench[peers]'``); nothing here
imports them at import time: those two are registered only when their library can be found.
"""
