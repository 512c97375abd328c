"""Checkpoints of a `Scheme` run, for restarting long production runs.

A checkpoint is a ``.npz`` file holding the step number, the time, the coefficient
vectors of the state (vⁿ, pⁿ) and the displacement uⁿ_h (which gives σⁿ_h, see `scheme`) with the
time scheme's history (`Scheme.history`: BDF2's level n − 1, the θ-scheme's multiplier), a
fingerprint of the discretisation and a JSON ``extra`` dictionary (histories, the
entries of a `output.VTKSeries`, …). Restoring is exact: a resumed run reproduces the
uninterrupted one bit for bit.

Under mpirun rank 0 gathers every rank's local vectors (cumulated) and fingerprint into the one file
(``state.rank1``, …; the fingerprint lists the ranks), and scatters them back on loading; a checkpoint
resumes only with the number of ranks that wrote it (the mesh's partition is part of the vectors' meaning).

    save_checkpoint(checkpoint_path(out, scheme.n), scheme, {"probes": probes.state()})
    ...
    path = latest_checkpoint(out)
    if path is not None:
        extra = load_checkpoint(path, scheme)
        probes.restore(extra["probes"])
"""
from __future__ import annotations

import hashlib
import json
import zipfile
from pathlib import Path

import numpy as np

from ..runtime import parallel
from . import atomic

FORMAT = 3  # 2: the displacement instead of the stress (lean operators); 3: time schemes
PREFIX = "checkpoint"


class CheckpointError(ValueError):
    """A checkpoint that cannot be read, or that belongs to another discretisation."""


def checkpoint_path(directory: str | Path, step: int) -> Path:
    """The conventional name ``checkpoint_{step:06d}.npz`` in ``directory``."""
    return Path(directory) / f"{PREFIX}_{step:06d}.npz"


def _mesh_hash(mesh) -> str:
    coords = np.ascontiguousarray(np.asarray(mesh.ngmesh.Coordinates(), dtype=np.float64))
    digest = hashlib.sha256(coords.tobytes())
    digest.update(f"{mesh.dim}:{mesh.nv}:{mesh.ne}".encode())
    return digest.hexdigest()[:16]


def fingerprint(scheme) -> dict:
    """What a checkpoint must share with the run that loads it: the spaces (family, order,
    number of dofs), the mesh (size and a hash of its vertex coordinates), Δt, the time scheme,
    the materials (by region where regions have their own) and the outlets, flow-rate inflows and supports."""
    spaces, data = scheme.spaces, scheme.data
    mesh = spaces.mesh
    boundaries = {**{name: {"outlet": model.record()} for name, model in data.outlets.items()},
                  **{name: {"flow": rate.record()} for name, rate in data.boundary_flow.items()},
                  **{name: {"support": [float(s.stiffness), float(s.damping)]} for name, s in data.supports.items()}}
    return {
        "format": FORMAT,
        "dim": mesh.dim,
        "family": spaces.family,
        "order": spaces.order,
        "vertices": mesh.nv,
        "cells": mesh.ne,
        "mesh": _mesh_hash(mesh),
        "ndof_velocity": spaces.velocity.ndof,
        "ndof_pressure": spaces.pressure.ndof,
        "ndof_stress": spaces.stress.ndof,
        "ndof_mixed": spaces.mixed.ndof,
        "dt": float(scheme.dt),
        "time_scheme": {"name": scheme.time_scheme.name, "theta": float(scheme.time_scheme.theta)},
        "materials": scheme.materials.as_dict(),
        **({"boundaries": boundaries} if boundaries else {}),
    }


def _vectors(scheme) -> dict[str, np.ndarray]:
    """The scheme's history vectors (this rank's part, cumulated under MPI) and arrays, as views."""
    vectors = scheme.history()
    for vector in vectors.values():
        if hasattr(vector, "Cumulate") and parallel.distributed():
            vector.Cumulate()
    return {name: vector if isinstance(vector, np.ndarray) else vector.FV().NumPy() for name, vector in vectors.items()}


def _key(name: str, rank: int, ranks: int) -> str:
    return name if ranks == 1 else f"{name}.rank{rank}"


def _combined(prints: list[dict]) -> dict:
    """The fingerprint of a run on ``len(prints)`` ranks (one rank: its own)."""
    return prints[0] if len(prints) == 1 else {"ranks": len(prints), "parts": prints}


def save_checkpoint(path: str | Path, scheme, extra: dict | None = None) -> Path:
    """Store the scheme's step, time and vectors with ``extra`` (JSON-serialisable; rank 0's under MPI).

    The file is written to a temporary file in the same directory, synced, and renamed
    over ``path``: an existing checkpoint is replaced only by a complete one.
    """
    path = Path(path)
    extra_json = json.dumps(extra or {})  # fails (TypeError) before anything is written
    vectors = {name: np.array(values, dtype=np.float64) for name, values in _vectors(scheme).items()}
    parts = parallel.gather_on_root((vectors, fingerprint(scheme)))
    parallel.shared(_write, path, parts, scheme.n, scheme.time, extra_json)
    return path


def _write(path: Path, parts: list[tuple[dict, dict]], step: int, time: float, extra_json: str) -> None:
    arrays = {_key(name, rank, len(parts)): values for rank, (vectors, _) in enumerate(parts)
              for name, values in vectors.items()}
    arrays.update(
        format=np.array(FORMAT, dtype=np.int64),
        step=np.array(int(step), dtype=np.int64),
        time=np.array(float(time), dtype=np.float64),
        fingerprint=np.array(json.dumps(_combined([prints for _, prints in parts]), sort_keys=True)),
        extra=np.frombuffer(extra_json.encode(), dtype=np.uint8),  # UTF-8 bytes, not 4-byte characters
    )
    with atomic.replacing(path) as tmp, open(tmp, "wb") as handle:
        np.savez_compressed(handle, **arrays)


def _read(path: Path) -> dict:
    try:
        with np.load(path, allow_pickle=False) as data:
            contents = {name: data[name] for name in data.files}
    except FileNotFoundError:
        raise
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise CheckpointError(f"checkpoint {path}: not a readable checkpoint ({exc})") from None
    missing = {"format", "step", "time", "fingerprint", "extra"} - contents.keys()
    if missing or not any(name.split(".")[0] == "state" for name in contents):
        missing |= {"state"}
        raise CheckpointError(f"checkpoint {path}: not a fsivsp checkpoint (missing {', '.join(sorted(missing))})")
    return contents


def _mismatches(saved: dict, current: dict, prefix: str = "") -> list[str]:
    out = []
    for key in sorted(saved.keys() | current.keys()):
        a, b = saved.get(key), current.get(key)
        if isinstance(a, dict) and isinstance(b, dict):
            out += _mismatches(a, b, f"{prefix}{key}.")
        elif a != b:
            out.append(f"{prefix}{key} {a!r} (checkpoint) vs {b!r} (this run)")
    return out


def load_checkpoint(path: str | Path, scheme) -> dict:
    """Restore step, time and vectors into ``scheme`` exactly; return the saved ``extra``.

    Raises `CheckpointError` (on every rank) if the file is unreadable or was written for another
    discretisation (different mesh, spaces, Δt, materials or number of ranks).
    """
    path = Path(path)
    targets = _vectors(scheme)
    current = parallel.gather_on_root((fingerprint(scheme), {name: target.shape for name, target in targets.items()}))
    loaded = parallel.on_root(_read_matching, path, current)
    for name, values in parallel.scatter(loaded[0] if loaded else None).items():
        targets[name][:] = values
    step, time, extra = parallel.shared(lambda: loaded[1])
    scheme.time, scheme.n = time, step
    return extra


def _read_matching(path: Path, current: list[tuple[dict, dict]]) -> tuple[list[dict], tuple[int, float, dict]]:
    """Each rank's vectors of the checkpoint at ``path`` and its (step, time, extra), if it matches the run whose
    ranks have the (fingerprint, vector shapes) ``current``."""
    contents = _read(path)
    saved = json.loads(str(contents["fingerprint"]))
    ranks = saved.get("ranks", 1) if "parts" in saved else 1
    if ranks != len(current):
        how = f"with mpirun -np {ranks}" if ranks > 1 else "without mpirun"
        raise CheckpointError(f"checkpoint {path}: written by {ranks} rank{'s' * (ranks > 1)}, this run has "
                              f"{len(current)}; resume {how}")
    problems = _mismatches(saved, _combined([prints for prints, _ in current]))
    if problems:
        raise CheckpointError(f"checkpoint {path}: does not match this run: {'; '.join(problems)}")
    vectors = []
    for rank, (_, shapes) in enumerate(current):
        mine = {}
        for name, shape in shapes.items():
            values = contents.get(_key(name, rank, ranks))
            if values is None or values.shape != shape:
                raise CheckpointError(f"checkpoint {path}: {_key(name, rank, ranks)} has shape "
                                      f"{None if values is None else values.shape}, expected {shape}")
            mine[name] = values
        vectors.append(mine)
    return vectors, (int(contents["step"]), float(contents["time"]), json.loads(contents["extra"].tobytes().decode()))


def prune_checkpoints(directory: str | Path, keep: int = 2) -> None:
    """Delete all but the ``keep`` newest checkpoints (by step) in ``directory``."""
    def step(path: Path) -> int:
        digits = path.stem.rsplit("_", 1)[-1]
        return int(digits) if digits.isdigit() else -1

    found = sorted(Path(directory).glob(f"{PREFIX}_*.npz"), key=step)
    for old in found[:-keep] if keep > 0 else found:
        old.unlink(missing_ok=True)


def latest_checkpoint(directory: str | Path, report=None) -> Path | None:
    """The readable ``checkpoint*.npz`` in ``directory`` with the highest step (the newest
    file among equal steps), or None. Temporary and unreadable files are skipped; ``report(path, reason)`` is
    told of each unreadable one."""
    directory = Path(directory)
    if not directory.is_dir():
        return None
    best, best_key = None, None
    for path in directory.glob(f"{PREFIX}*.npz"):
        if not path.is_file():
            continue
        try:
            with np.load(path, allow_pickle=False) as data:
                step = int(data["step"])
        except Exception as error:  # a damaged or foreign file is no candidate
            if report is not None:
                report(path, error)
            continue
        key = (step, path.stat().st_mtime_ns, path.name)
        if best_key is None or key > best_key:
            best, best_key = path, key
    return best
