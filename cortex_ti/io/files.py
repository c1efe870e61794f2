"""Small files of a run and of the workflow, written atomically: JSON summaries, xarray stores;
and the Snakemake benchmark files read back."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from ..errors import CortexError

__all__ = [
    "PARTIAL_SUFFIX",
    "OutputError",
    "atomic_path",
    "check_destination",
    "hdf5_os_error",
    "write_synced",
    "describe_os_error",
    "refuse_file_parent",
    "write_json",
    "write_dataset",
    "read_benchmark",
]

#: Suffix of a file being written (renamed when complete).
PARTIAL_SUFFIX = ".partial"


def atomic_path(path: str | os.PathLike) -> tuple[Path, Path]:
    """``(final, temporary)`` paths of an atomic write; the folder is created."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return path, path.with_name(path.name + PARTIAL_SUFFIX)


def read_benchmark(path) -> dict[str, float]:
    """The first row of a Snakemake ``benchmark:`` TSV (wall ``s``, ``max_rss`` in MB, ``cpu_time``...)."""
    lines = Path(path).read_text().strip().splitlines()
    if len(lines) < 2:
        raise ValueError(f"benchmark file '{path}' has no data row")
    keys, values = lines[0].split("\t"), lines[1].split("\t")
    out = {}
    for k, v in zip(keys, values, strict=False):
        try:
            out[k] = float(v)
        except ValueError:
            out[k] = np.nan
    return out


def write_json(obj, path: str | os.PathLike) -> Path:
    """Write ``obj`` as JSON atomically (temporary name, then rename); NaN becomes null."""

    def clean(v):
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if isinstance(v, np.generic):
            return clean(v.item())
        return v

    path, tmp = atomic_path(path)
    try:
        tmp.write_text(json.dumps(clean(obj), indent=1, allow_nan=False) + "\n")
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def write_dataset(ds, path: str | os.PathLike) -> Path:
    """Write an xarray Dataset (netCDF4 layout through h5netcdf) atomically: temporary name, then rename."""
    path, tmp = atomic_path(path)
    try:
        ds.to_netcdf(tmp, engine="h5netcdf")
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


class OutputError(CortexError):
    """Writing an output failed (full disk, I/O error, a folder that cannot be written): the message
    says what failed, which file, and what was kept."""


def refuse_file_parent(path: Path, what: str) -> None:
    """Refuse, before anything is computed, an output ``path`` whose folder (or a parent) is a file."""
    for parent in Path(path).parents:
        if parent.exists():
            if not parent.is_dir():
                raise CortexError(f"cannot write {what} '{path}': '{parent}' is a file, not a folder")
            return


def describe_os_error(exc: OSError) -> str:
    """An operating-system error as words with its file: ``No space left on device: 'x.h5'``."""
    import errno

    if exc.errno in (errno.EEXIST, errno.ENOTDIR) and exc.filename is not None:
        # mkdir of a folder whose name, or a parent's, is a file
        for p in (Path(os.fsdecode(exc.filename)), *Path(os.fsdecode(exc.filename)).parents):
            if p.exists() and not p.is_dir():
                return f"'{p}' is a file, not a folder"
    what = exc.strerror or str(exc) or type(exc).__name__
    names = [n for n in (exc.filename, exc.filename2) if n is not None]
    return what + "".join(f": '{os.fsdecode(n)}'" for n in names)


def write_synced(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` and fsync it (an OSError for a full disk, the file then deleted
    by the caller)."""
    with open(path, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())


def check_destination(path: Path, need: int = 0) -> None:
    """Before anything is computed: ``path``'s folder can be written (created if needed, a file
    made in it and removed) and has ``need`` bytes free (checked where cheap,
    :func:`shutil.disk_usage`). Else one :class:`~cortex_ti.io.files.OutputError`."""
    import shutil

    path = Path(path)
    refuse_file_parent(path, "the output")
    probe = path.with_name(f".{path.name}.probe")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(probe, "x"):
            pass
        probe.unlink()
        free = shutil.disk_usage(path.parent).free
    except OSError as exc:
        raise OutputError(f"cannot write '{path}': {describe_os_error(exc)}; nothing was written") from None
    if need > free:
        raise OutputError(
            f"cannot write '{path}': it needs about {need / 1e6:.3g} MB and '{path.parent}' has "
            f"{free / 1e6:.3g} MB free; nothing was written"
        )


def hdf5_os_error(exc: BaseException) -> str | None:
    """The operating-system error inside an HDF5 error (h5py raises a RuntimeError "... file write
    failed: ..., errno = 28, error message = 'No space left on device' ..."), as words; else None."""
    import re

    if not isinstance(exc, RuntimeError):
        return None
    found = re.search(r"errno = (\d+), error message = '([^']*)'", str(exc))
    return None if found is None else found.group(2) or os.strerror(int(found.group(1)))
