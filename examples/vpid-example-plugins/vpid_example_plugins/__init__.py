"""Two example vpid-bench plugins in one third-party package (see the README's plugin
sections): ``optimizer=one_plus_one`` (one_plus_one.py) and ``problem=quarter_car``
(quarter_car.py). Each module is named by an entry point in pyproject.toml."""
