"""What made an output file: the package's version, its git commit and the versions of the main
dependencies, written into the attributes of every trajectory and every workflow store.

One function, :func:`provenance`, used by every writer, so the files agree on the keys. It imports
nothing beyond the standard library (the dependencies' versions come from their installed metadata,
so asking for Taichi's version does not start Taichi), and sits at the bottom of the layers with
``errors``.

>>> import cortex_ti
>>> p = cortex_ti.provenance()
>>> sorted(p) == sorted(PROVENANCE_KEYS)
True
>>> p["cortex_ti_version"] == cortex_ti.__version__
True
"""

from __future__ import annotations

import functools
import platform
import subprocess
from importlib import metadata
from pathlib import Path

__all__ = ["DEPENDENCIES", "PROVENANCE_KEYS", "git_commit", "package_version", "provenance"]

#: The distributions whose versions an output file records (the ones that change its numbers or its layout)
DEPENDENCIES = ("numpy", "scipy", "taichi", "xarray", "h5netcdf")

#: The attribute names :func:`provenance` returns
PROVENANCE_KEYS = (
    "cortex_ti_version",
    "cortex_ti_commit",
    "python_version",
    *(f"{name}_version" for name in DEPENDENCIES),
)

_PACKAGE_DIR = Path(__file__).resolve().parent
#: Written into a file when the version or the commit cannot be found (an attribute is never missing)
UNKNOWN = "unknown"


@functools.lru_cache(maxsize=1)
def package_version() -> str:
    """The package's version: from setuptools-scm at build time (``cortex_ti/_version.py``: the
    latest tag, or ``0.1.1.devN+g<commit>`` without one, counted from the fallback 0.1.0), else the
    installed metadata, else unknown. The file is written when the package is built or installed,
    so in a checkout it can lag behind later commits: the commit in :func:`provenance` is read
    from git at run time."""
    try:
        from ._version import version  # written by setuptools-scm when the package is built or installed

        return str(version)
    except ImportError:
        pass
    try:
        return metadata.version("cortex-ti")
    except metadata.PackageNotFoundError:
        return f"0+{UNKNOWN}"


@functools.lru_cache(maxsize=1)
def git_commit() -> str | None:
    """The commit of the git checkout this package is imported from, with ``-dirty`` when tracked
    files differ from it; None when the package is not in a git checkout (a wheel, an archive) or
    git is not there. Asked once per process."""

    def git(*args):
        return subprocess.run(["git", *args], cwd=_PACKAGE_DIR, capture_output=True, text=True, timeout=10)

    try:
        top = git("rev-parse", "--show-toplevel")
        # only the checkout that holds this package (not some repository a site-packages lies in)
        if top.returncode != 0 or Path(top.stdout.strip()).resolve() != _PACKAGE_DIR.parent:
            return None
        head = git("rev-parse", "HEAD")
        if head.returncode != 0:
            return None
        dirty = git("status", "--porcelain", "--untracked-files=no", "--", str(_PACKAGE_DIR))
        return head.stdout.strip() + ("-dirty" if dirty.returncode == 0 and dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        return None


def _distribution_version(name: str) -> str:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return UNKNOWN


def provenance() -> dict[str, str]:
    """The attributes an output file carries about what made it (all strings, keys
    :data:`PROVENANCE_KEYS`): ``cortex_ti_version``, ``cortex_ti_commit`` (``unknown`` outside a
    git checkout), ``python_version`` and ``<dependency>_version`` for :data:`DEPENDENCIES`."""
    out = {
        "cortex_ti_version": package_version(),
        "cortex_ti_commit": git_commit() or UNKNOWN,
        "python_version": platform.python_version(),
    }
    out.update({f"{name}_version": _distribution_version(name) for name in DEPENDENCIES})
    return out
