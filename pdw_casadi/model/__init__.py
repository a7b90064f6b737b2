"""Layer 2, the model: a walker as data and as CasADi symbolic functions.

- :mod:`.problem`: the problem file (anthropometry, compliance, section state, bounds);
- :mod:`.mechanics`: planar rigid bodies, contacts, rolling arcs, joint torques;
- :mod:`.hybrid`: phases, guards and impact maps of a hybrid walker;
- :mod:`.walkers`: the walker families, each building a hybrid model from a problem;
- :mod:`.system`: the hybrid system of a problem (built once, cached by the problem);
- :mod:`.margins`: validity margins (normal forces, centres of pressure, clearances);
- :mod:`.units`: physical units of every named quantity;
- :mod:`.gait_data`: human gait curve files;
- :mod:`.faces`: the drawing geometry of a walker.
"""
