"""The shell: the only room of vpid-bench that knows Hydra (the ``vpid-bench`` command, its
command line, the pre-flight, composition, config nodes, callbacks and resume)."""
