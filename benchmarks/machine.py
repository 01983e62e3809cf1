"""The machine and library versions, printed with every benchmark."""

from __future__ import annotations

import importlib
import os
import platform


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "?"


def machine_info(modules=("numpy", "numba", "scipy", "ballchain")) -> str:
    """One line: CPU, cores, OS, python and the versions of ``modules``."""
    versions = []
    for name in modules:
        mod = importlib.import_module(name)
        versions.append(f"{name} {getattr(mod, '__version__', '?')}")
    return (
        f"machine: {cpu_model()}, {os.cpu_count()} cores, {platform.system()} {platform.release()}; "
        f"python {platform.python_version()}, " + ", ".join(versions)
    )
