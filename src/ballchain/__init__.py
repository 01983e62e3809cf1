"""ballchain: event-driven 3D simulation of a falling ball chain (Itano & Sugihara-Seki).

``import ballchain as bc`` gives the whole Python interface (``ballchain.api``):
``bc.simulate``, ``bc.load``, ``bc.save``, ``bc.sweep``, ``bc.stats``, the parameter
classes and ``bc.Result``.  They are imported on first use, so ``import ballchain`` stays
light (no numba, dask, matplotlib or plotly until needed).
"""

__version__ = "0.2.0"  # the one place: hatch reads it for the wheel; `ballchain --version` prints it

_LAZY = {
    "simulate": ("ballchain.api", "simulate"),
    "load": ("ballchain.api", "load"),
    "save": ("ballchain.api", "save"),
    "sweep": ("ballchain.api", "sweep"),
    "stats": ("ballchain.api", "stats"),
    "ChainParams": ("ballchain.model", "ChainParams"),
    "InitialCondition": ("ballchain.model", "InitialCondition"),
    "SolverOptions": ("ballchain.model", "SolverOptions"),
    "ParameterError": ("ballchain.errors", "ParameterError"),
    "Result": ("ballchain.records.result", "Result"),
}
__all__ = ["__version__", *_LAZY]


def __getattr__(name):
    if name in _LAZY:
        import importlib

        module, attr = _LAZY[name]
        value = getattr(importlib.import_module(module), attr)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'ballchain' has no attribute {name!r}")


def __dir__():
    return sorted(__all__)
