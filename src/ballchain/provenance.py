"""Where a number comes from: a fingerprint of the engine that computed it.

The fingerprint hashes the source of every module whose code decides a run's numbers (the
compiled core, the methods, the floor models, the contact laws, the parameters, the starts and the run itself),
so it changes with any edit of the engine, whether or not the package version does.
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
# the sub-packages and modules whose code decides a run's numbers
ENGINE_PACKAGES = ("core", "methods", "floors", "contacts")
ENGINE_MODULES = ("model.py", "initial.py", "engine.py", "jit.py", "options.py")


def engine_sources(root: Path = PACKAGE_DIR) -> list[Path]:
    """The engine's source files under the package directory ``root``, in a fixed order."""
    files = [root / name for name in ENGINE_MODULES if (root / name).is_file()]
    for pkg in ENGINE_PACKAGES:
        if (root / pkg).is_dir():
            files += sorted(p for p in (root / pkg).rglob("*.py") if "__pycache__" not in p.parts)
    return files


def fingerprint_of(root: Path) -> str:
    """sha256 (first 12 hex digits) over the relative paths and bytes of ``engine_sources(root)``."""
    h = hashlib.sha256()
    for path in engine_sources(root):
        h.update(path.relative_to(root).as_posix().encode())
        h.update(b"\0")
        h.update(path.read_bytes())
        h.update(b"\0")
    return h.hexdigest()[:12]


@functools.lru_cache(maxsize=1)
def engine_fingerprint() -> str:
    """The installed engine's fingerprint (``fingerprint_of`` the package), once per process."""
    return fingerprint_of(PACKAGE_DIR)
