"""The EMPS positioning rig as a vpid-bench problem (``problem=emps``): measured data, no
truth. See :mod:`.problem`."""
