"""The baselines every report compares against, ``optimizer=random`` and ``centre``, shipped
with vpid-bench so that they are always installed: an optimizer that does not beat random
search at the same budget has learned nothing from the objective (docs/baselines.md)."""
