"""``optimizer=random``: the baselines every report compares against (first-party plugin).

Random search is the null baseline: an optimizer that does not beat it at the same budget has
learned nothing from the objective. It ships with vpid-bench so that the baseline a report
leans on is always installed; see docs/baselines.md.
"""
