"""Layer 1, the engine: numerical machinery that knows nothing about walkers.

- :mod:`.compile`: CasADi functions compiled to C once and cached on disk;
- :mod:`.callback`: a numeric function wrapped as a CasADi callback;
- :mod:`.rk4`: fixed-step RK4 and its sensitivities;
- :mod:`.parallel`: one map over tasks (serial, a local process pool or Dask);
- :mod:`.errors`: the exception types every layer raises;
- :mod:`.resources`: the bundled problem and data files;
- :mod:`.jsonio`: JSON output with numpy values;
- :mod:`.interrupt`: Ctrl-C and SIGTERM that no solver swallows.
"""
