"""``builder``: a memoised builder of compiled programs whose cache key is the call's meaning, not its spelling.

``functools.lru_cache`` keys a call by how its arguments were written: ``f(task, agent, steps)`` and ``f(task,
agent, steps, "low_dim")`` (the default written out) or ``f(task, steps=4)`` and ``f(task, 4)`` are different
entries, so each builds its own jitted function and XLA compiles the same program twice (the GPU check's dry run
compiled the e2e stage's Lift evaluators again in its cell stage, about 3 minutes each on a CPU). ``builder`` binds
the call to the signature and fills in the defaults first, so every spelling of one call shares one entry.
"""

from __future__ import annotations

import functools
import inspect


def builder(fn=None, *, maxsize: int | None = None):
    """Decorator (``@builder`` or ``@builder(maxsize=8)``): `fn` memoised on its bound arguments with the defaults
    applied; ``cache_clear`` and ``cache_info`` as on an lru_cache."""
    if fn is None:
        return functools.partial(builder, maxsize=maxsize)
    sig = inspect.signature(fn)

    @functools.lru_cache(maxsize=maxsize)
    def by_meaning(*values):
        return fn(**dict(zip(sig.parameters, values)))

    @functools.wraps(fn)
    def call(*args, **kwargs):
        bound = sig.bind(*args, **kwargs)
        bound.apply_defaults()
        return by_meaning(*bound.arguments.values())

    call.cache_clear = by_meaning.cache_clear
    call.cache_info = by_meaning.cache_info
    return call
