"""Compiled copies of one kernel with some of the names it calls bound to other kernels.

numba compiles a function with everything it can reach: a kernel that picks a closed form at run time
(``if fam == SPH: solve_sph(...) elif ...``) compiles every family's closed form on its first call,
though a robot only ever uses one. :func:`specialise` makes a copy of a kernel's Python function whose
global names listed in ``names`` point elsewhere (``FAMILY=family_3p``, say), and compiles that copy
only when it is called. Each copy has a qualified name of its own (``solve_pose__three_parallel``) and
so its own entry in numba's on-disk cache (:mod:`pipeline._numba_cache`, which stamps it with the
source it can reach like any kernel of its module).

The rebound names must be other compiled functions or constants: a copy refers to them by global
name, so numba freezes them at compile time, as it does every global. (Passing a kernel to another
in a closure cell does not do: numba keys the cache on the pickled cells, and a pickled dispatcher
carries a per-process id, so the copy would compile again in every process.)
"""

from __future__ import annotations

import types

import numba


def specialise(template, tag: str, options: dict, **names):
    """A numba dispatcher of ``template`` (a plain Python function) with global ``names`` rebound.

    Parameters
    ----------
    template : function   the kernel's source, written against the names it calls
    tag : str             what distinguishes this copy (part of its qualified name and cache file)
    options : dict        numba.njit options (``cache=True`` for an on-disk cache)
    **names               global name -> compiled function or constant, for this copy only

    The copy sees the template module's globals as they are at this call, with ``names`` over them: build
    the copies after the module has finished loading (at the first call, for example).
    """
    return _compiled_copy(template, {**template.__globals__, **names}, tag, options)


def closed_to(dispatcher, signature: tuple):
    """``dispatcher`` compiled for ``signature`` (once) and closed to any other, returned: a caller may hand
    it its arrays unchecked, since any other type (another dtype or layout, read-only, a list) raises the
    TypeError on which the caller converts them (the fused single calls)."""
    if signature not in dispatcher.overloads:
        dispatcher.compile(signature)
        dispatcher.disable_compile()
    return dispatcher


def _compiled_copy(py, g: dict, tag: str, options: dict):
    """A numba dispatcher of a copy of function ``py`` whose globals are ``g`` and whose qualified name ends
    in ``__tag`` (its own cache file); ``options`` as numba.njit takes them (``nopython`` is implied)."""
    f = types.FunctionType(py.__code__, g, py.__name__, py.__defaults__, py.__closure__)
    f.__qualname__ = f"{py.__qualname__}__{tag}"
    f.__module__, f.__doc__, f.__kwdefaults__ = py.__module__, py.__doc__, py.__kwdefaults__
    return numba.njit(**{k: v for k, v in options.items() if k != "nopython"})(f)


def inlined_twin(*modules, suffix: str = "inline"):
    """A module object holding the globals of ``modules`` with each of their compiled functions replaced,
    by name, by a twin that numba inlines at every call site (``inline="always"``), calling the other twins.

    For code that must see a chain of small kernels as one body, such as a pass that the compiler turns
    into vector code only when no call is left in it (the 8-goal lane passes of
    :mod:`pipeline.solvers.closed_form.family_sph` and :mod:`~pipeline.solvers.closed_form.family_3p`), while
    the kernels themselves stay separate functions elsewhere (inlining at numba's level copies a callee's
    code into every call site, which multiplies the compiler's work: a single closed-form call compiled
    in minutes with everything inlined and seconds without; the single calls inline the few stages that
    pay for their compile time, :func:`~pipeline.solvers.closed_form.family_3p.solve_3p`).
    The twins compute the same floats as the originals (the same operations in the same order; no
    fast-math).

    Parameters
    ----------
    *modules : module     whose compiled functions (those defined in the module itself) are twinned; a
                          module's globals that are another one's compiled functions (``from x import f``)
                          point to the twin of ``f``, so a stage of one module calls the twins of the
                          building blocks of another. A module may be the one being loaded
                          (``sys.modules[__name__]``): its functions defined so far are twinned.
    suffix : str          the twins' qualified-name suffix

    Two modules defining compiled functions of the same name are refused (ValueError): the twins share
    one namespace.
    """
    twin = types.ModuleType(f"{modules[-1].__name__}__{suffix}")
    g = twin.__dict__
    own = {}
    for module in modules:
        g.update({k: v for k, v in vars(module).items() if k not in ("__name__", "__spec__", "__loader__")})
        for name, obj in vars(module).items():
            py = getattr(obj, "py_func", None)
            if py is None or getattr(py, "__module__", None) != module.__name__ or not hasattr(obj, "targetoptions"):
                continue
            if name in own:
                raise ValueError(f"inlined_twin: {name} is defined in both {own[name][0]} and {module.__name__}")
            own[name] = (module.__name__, py, obj.targetoptions)
    for name, (_, py, targetoptions) in own.items():
        options = {k: v for k, v in targetoptions.items() if k not in ("inline", "cache")}
        g[name] = _compiled_copy(py, g, suffix, {**options, "inline": "always"})
    return twin
