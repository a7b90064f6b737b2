"""Layer 3, gaits: simulation of the hybrid walker and the periodic gaits it has.

- :mod:`.simulate`: the hybrid simulator with exact event location;
- :mod:`.poincare`: the Poincare map and its exact AD Jacobian;
- :mod:`.fixed_point`: periodic gaits (fixed points) and their stability;
- :mod:`.stability`: the spectral radius a gait must have to be accepted (one home);
- :mod:`.stride`: the stride map of a walker whose legs differ;
- :mod:`.continuation`, :mod:`.bifurcation`, :mod:`.sweep`: parameter sweeps;
- :mod:`.design`: parameters that put a gait where it is wanted, by continuation;
- :mod:`.timing`: gait events and timing;
- :mod:`.curves`: joint-angle curves over a gait cycle and their R^2.
"""
