"""CasADi functions evaluated by Python code, with a Jacobian given the same way.

An MX graph (the fit NLP) can call code CasADi cannot differentiate by itself: a compiled
library, or numpy around the simulator. :class:`NumericFunction` wraps such code as a
:class:`casadi.Callback`; ``jacobian(name)`` returns the function CasADi then uses for all
derivatives (inputs: the inputs followed by the nominal outputs; outputs: the blocks).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import casadi as ca
import numpy as np

from pdw_casadi.engine import interrupt


class NumericFunction(ca.Callback):
    """``evaluate(list of DM) -> list`` with fixed sparsities, and an optional Jacobian.

    ``buffers(inputs, outputs)``, given instead of ``evaluate`` (None), evaluates on
    CasADi's own nonzero buffers (each a 1-D float64 array of the structural nonzeros,
    column-major): the outputs are views to write in place, so no DM is built, which for
    an output of 10^5 nonzeros (the fit's constraint Jacobian) saves 10 ms per call; the
    inputs are copies, which the callee may keep (CasADi reuses its buffers after the
    call: the stability row keeps its last point's forward sweep, views of its input)."""

    def __init__(self, name: str, sparsity_in: Sequence[ca.Sparsity],
                 sparsity_out: Sequence[ca.Sparsity], evaluate: Callable | None,
                 jacobian: Callable[[str], ca.Function] | None = None,
                 names_in: Sequence[str] | None = None, names_out: Sequence[str] | None = None,
                 buffers: Callable | None = None):
        if (evaluate is None) == (buffers is None):
            raise ValueError(f"{name}: give evaluate or buffers, one of them")
        ca.Callback.__init__(self)
        self._sp_in, self._sp_out = list(sparsity_in), list(sparsity_out)
        self._names_in = list(names_in or [f"i{i}" for i in range(len(self._sp_in))])
        self._names_out = list(names_out or [f"o{i}" for i in range(len(self._sp_out))])
        self._evaluate, self._jacobian, self._buffers = evaluate, jacobian, buffers
        self.construct(name, {})

    @classmethod
    def wrap(cls, name: str, template: ca.Function, call: ca.Function | None = None,
             jacobian: Callable[[str], ca.Function] | None = None) -> NumericFunction:
        """``call`` (default ``template``) with ``template``'s signature."""
        call = call or template
        return cls(name, [template.sparsity_in(i) for i in range(template.n_in())],
                   [template.sparsity_out(i) for i in range(template.n_out())], call.call,
                   jacobian, template.name_in(), template.name_out())

    def get_n_in(self):
        return len(self._sp_in)

    def get_n_out(self):
        return len(self._sp_out)

    def get_sparsity_in(self, i):
        return self._sp_in[i]

    def get_sparsity_out(self, i):
        return self._sp_out[i]

    def get_name_in(self, i):
        return self._names_in[i]

    def get_name_out(self, i):
        return self._names_out[i]

    def eval(self, arg):
        # a pending Ctrl-C: no more work inside the solver (CasADi evaluates the NLP once
        # more after IPOPT stops, seconds for the stability row)
        interrupt.check()
        return self._evaluate(arg)

    def has_eval_buffer(self):
        return self._buffers is not None

    def eval_buffer(self, arg, res):
        interrupt.check()  # as eval
        self._buffers([np.frombuffer(a, dtype=np.float64).copy() for a in arg],
                      [np.frombuffer(r, dtype=np.float64) for r in res])
        return 0

    def has_jacobian(self):
        return self._jacobian is not None

    def get_jacobian(self, name, inames, onames, opts):
        self._jac = self._jacobian(name)  # keep a reference: CasADi does not
        return self._jac
