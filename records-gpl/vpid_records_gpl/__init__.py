"""Data only: the Bayesrace simulator's records and a full-scale racecar's logs, copied byte for
byte from linklab-uva/deep-dynamics (GPL-3.0, ``LICENSE`` in this folder). vpid-bench finds
this folder through ``importlib.resources`` and checks every file's SHA-256 before reading it.
"""
