"""Checkpoints as records in one HDF5 file, written and read without knowing the fields.

A checkpoint is a tree of named records (``{"solver": {...}, "solver/loads":
{...}, ...}``); each record maps names to values. Arrays become datasets, with
their dtype and shape kept exactly; every other value (numbers, strings, None,
lists, dicts) becomes a JSON attribute, so floats round-trip exactly. The
file's root carries :data:`FORMAT` and :data:`FORMAT_VERSION`; a reader meets
a file of another format or version with a one-line :class:`CheckpointError`
instead of a half-restored state.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from grainfrac.errors import CheckpointError
from grainfrac.io.files import write_atomic

FORMAT = "grainfrac checkpoint"
FORMAT_VERSION = 1

Record = Mapping[str, Any]


def write_checkpoint(path: str | Path, records: Mapping[str, Record]) -> Path:
    """Write ``records`` (group path -> record) into ``path`` atomically."""

    def write(tmp: Path) -> None:
        with h5py.File(tmp, "w") as f:
            f.attrs["format"] = FORMAT
            f.attrs["format_version"] = FORMAT_VERSION
            for group_path, record in records.items():
                group = f.require_group(group_path)
                for name, value in record.items():
                    if isinstance(value, np.ndarray):
                        group.create_dataset(name, data=value)
                    else:
                        group.attrs[name] = json.dumps(value)

    return write_atomic(path, write)


def read_checkpoint(path: str | Path) -> dict[str, dict[str, Any]]:
    """The records of a checkpoint written by :func:`write_checkpoint`.

    Raises :class:`CheckpointError` for a file of an older grainfrac (the
    ``.npz`` checkpoints before format 1), another format version, or a file
    that is not a checkpoint.
    """
    path = Path(path)
    if not h5py.is_hdf5(path):
        if path.suffix == ".npz":
            raise CheckpointError(
                f"{path} is a checkpoint of an older grainfrac (.npz); this version reads "
                f"format {FORMAT_VERSION} (.h5) only: run the scenario again without --resume")
        raise CheckpointError(f"{path} is not a grainfrac checkpoint (not an HDF5 file)")
    try:
        return _read(path)
    except (OSError, ValueError, KeyError, RuntimeError) as exc:
        # h5py reports a truncated or damaged file as OSError (or KeyError/RuntimeError on a
        # damaged object), a damaged attribute as a JSON ValueError.
        first = (str(exc).splitlines() or [""])[0][:120]
        raise CheckpointError(f"{path} is damaged or truncated and cannot be read "
                              f"({type(exc).__name__}: {first}); run the scenario again "
                              "without --resume") from None


def _read(path: Path) -> dict[str, dict[str, Any]]:
    records: dict[str, dict[str, Any]] = {}
    with h5py.File(path, "r") as f:
        kind, version = f.attrs.get("format"), f.attrs.get("format_version")
        if kind != FORMAT:
            raise CheckpointError(f"{path} is not a grainfrac checkpoint (format {kind!r})")
        if version != FORMAT_VERSION:
            raise CheckpointError(
                f"{path} is a checkpoint of format version {version}; this grainfrac reads "
                f"version {FORMAT_VERSION}: run the scenario again without --resume")

        def read(name: str, group: h5py.Group) -> None:
            if not isinstance(group, h5py.Group):
                return
            record = {key: json.loads(value) for key, value in group.attrs.items()}
            for key, item in group.items():
                if isinstance(item, h5py.Dataset):
                    record[key] = item[()]
            records[name] = record

        f.visititems(read)
    return records
