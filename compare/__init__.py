"""compare: run talus, LIGGGHTS and YADE on the same set-ups and check talus's figures.

Every engine writes a raw time series; the figures (restitution, contact duration,
peak overlap and force, tangential rebound, spin; discharge rate and wall loads)
are computed from those series by one piece of code (`figures.py`), so the three
engines are measured the same way.
"""
