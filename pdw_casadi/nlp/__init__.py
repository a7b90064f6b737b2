"""Layer 4, the NLP: multiple-shooting transcription of a periodic gait for IPOPT.

- :mod:`.shooting`: the shooting NLP (decision vector, interval and event constraints);
- :mod:`.interval`: one shooting interval as a compiled function;
- :mod:`.stability`: the stability row (spectral-radius bound with an exact gradient).
"""
