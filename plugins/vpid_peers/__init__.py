"""vpid-bench's first-party peers of the paper's DE variants: scipy's differential evolution,
multistart least squares on the residuals (IRLS for a sum of norms) and a DE4 + least-squares
hybrid. See docs/peers.md."""
