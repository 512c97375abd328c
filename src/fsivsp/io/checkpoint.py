"""Checkpoints of a `Scheme` run, for restarting long production runs.

A checkpoint is a ``.npz`` file holding the step number, the time, the coefficient
vectors of the state (vⁿ, pⁿ) and the displacement uⁿ_h (which gives σⁿ_h, see `scheme`) with the
time scheme's history (`Scheme.history`: BDF2's level n − 1, the θ-scheme's multiplier, the solutions before xⁿ
that the iterative solver's start combines, `timestepping.warmstart`), a
fingerprint of the discretisation and a JSON ``extra`` dictionary (histories, the
entries of a `output.VTKSeries`, …). Restoring is exact: a resumed run reproduces the
uninterrupted one bit for bit. Checkpoints of formats 3 (before the warm start) and 4 (xⁿ⁻¹ alone) are still read:
their next step's start combines the solutions they hold; older formats are refused in one line.

Under mpirun every rank writes its own part, ``checkpoint_{step}.parts/rank{r}.npz`` (its local vectors,
cumulated, and its fingerprint), and only then rank 0 writes the ``.npz`` file itself, the manifest: step, time,
``extra``, the number of ranks and a token its parts carry; each file atomically (`atomic`), so a checkpoint is
complete when its manifest exists. No rank gathers another's vectors. A checkpoint resumes only with the number of
ranks that wrote it: each part belongs to its rank's piece of the mesh (docs/mpi.md says what another number would
need).

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
import secrets
import shutil
import zipfile
from pathlib import Path

import numpy as np

from ..runtime import parallel
from . import atomic

#: 2: the displacement instead of the stress (lean operators); 3: time schemes; 4: xⁿ⁻¹ (warm start); 5: the solutions
#: before xⁿ that the minimal-residual start combines, and their count.
FORMAT = 5
#: The formats this version reads, and the vectors of `Scheme.history` a format added: a checkpoint of an older
#: format readable here lacks them and the scheme completes its history (`Scheme.complete_history`).
READABLE = (3, 4, 5)
ADDED = {"previous_solution": 4, "start_count": 5}
#: The format that added the start's older solutions (``previous_solution_2``, …).
ADDED_OLDER = 5
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


def parts_folder(path: Path) -> Path:
    """The folder of the ranks' parts of the checkpoint ``path`` (its manifest): ``checkpoint_{step}.parts``."""
    return path.with_suffix(".parts")


def part_path(path: Path, rank: int) -> Path:
    return parts_folder(path) / f"rank{rank:05d}.npz"


def save_checkpoint(path: str | Path, scheme, extra: dict | None = None) -> Path:
    """Store the scheme's step, time and vectors with ``extra`` (JSON-serialisable; rank 0's under MPI).

    Every file is written to a temporary file in the same directory, synced, and renamed
    over its name: an existing checkpoint is replaced only by a complete one (under MPI: the manifest, after every
    rank's part; a rank that cannot write its part raises the error on every rank).
    """
    path = Path(path)
    extra_json = json.dumps(extra or {})  # fails (TypeError) before anything is written
    vectors = {name: np.array(values, dtype=np.float64) for name, values in _vectors(scheme).items()}
    header = {"format": np.array(FORMAT, dtype=np.int64), "step": np.array(int(scheme.n), dtype=np.int64),
              "time": np.array(float(scheme.time), dtype=np.float64)}
    if not parallel.distributed():
        _write(path, {**vectors, **header, "fingerprint": _json(fingerprint(scheme)),
                      "extra": np.frombuffer(extra_json.encode(), dtype=np.uint8)})  # UTF-8 bytes, not 4-byte chars
        return path
    token = parallel.shared(secrets.token_hex, 8)
    parallel.together(_write, part_path(path, parallel.rank()),
                      {**vectors, **header, "fingerprint": _json(fingerprint(scheme)), "token": np.array(token)})
    parallel.shared(_write, path, {**header, "ranks": np.array(parallel.size(), dtype=np.int64),
                                   "token": np.array(token), "extra": np.frombuffer(extra_json.encode(), np.uint8)})
    return path


def _json(value: dict) -> np.ndarray:
    return np.array(json.dumps(value, sort_keys=True))


def _write(path: Path, arrays: dict[str, np.ndarray]) -> None:
    with atomic.replacing(path) as tmp, open(tmp, "wb") as handle:
        np.savez_compressed(handle, **arrays)


def _read(path: Path, required: set[str]) -> dict:
    try:
        with np.load(path, allow_pickle=False) as data:
            contents = {name: data[name] for name in data.files}
    except FileNotFoundError:
        raise CheckpointError(f"checkpoint {path}: missing") from None
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise CheckpointError(f"checkpoint {path}: not a readable checkpoint ({exc})") from None
    if missing := required - contents.keys():
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

    Raises `CheckpointError` (on every rank) if a file is unreadable or was written for another
    discretisation (different mesh, spaces, Δt, materials or number of ranks); the scheme is then unchanged.
    """
    path = Path(path)
    targets = _vectors(scheme)
    step, time, extra, token = parallel.shared(_read_manifest, path, parallel.size())
    part = path if token is None else part_path(path, parallel.rank())
    vectors = parallel.together(_read_part, part, fingerprint(scheme), targets, token)
    for name, values in vectors.items():
        targets[name][:] = values
    scheme.time, scheme.n = time, step
    scheme.restored(set(targets) - set(vectors))
    return extra


def _read_manifest(path: Path, ranks: int) -> tuple[int, float, dict, str | None]:
    """Step, time and ``extra`` of the checkpoint ``path`` and the token of its parts (None: a serial checkpoint,
    its vectors in the file itself), if it was written by ``ranks`` ranks."""
    contents = _read(path, {"format", "step", "time", "extra"})
    written = int(contents["ranks"]) if "ranks" in contents else 1
    if written != ranks:
        how = f"with mpirun -np {written}" if written > 1 else "without mpirun"
        raise CheckpointError(f"checkpoint {path}: written by {written} rank{'s' * (written > 1)}, this run has "
                              f"{ranks}; resume {how}")
    token = str(contents["token"]) if "token" in contents else None
    return (int(contents["step"]), float(contents["time"]), json.loads(contents["extra"].tobytes().decode()),
            token)


def added(name: str) -> int:
    """The format that added the history vector ``name`` (0: every readable format has it)."""
    return ADDED.get(name, ADDED_OLDER if name.startswith("previous_solution_") else 0)


def _read_part(path: Path, current: dict, targets: dict[str, np.ndarray], token: str | None) -> dict:
    """The vectors of the checkpoint file ``path`` (a serial checkpoint, or this rank's part carrying ``token``),
    if its fingerprint is ``current`` and its vectors have the shapes of ``targets``."""
    contents = _read(path, {"fingerprint", "state"})
    if token is not None and str(contents.get("token")) != token:
        raise CheckpointError(f"checkpoint {path}: belongs to another checkpoint than its manifest "
                              f"{path.parent.with_suffix('.npz')}")
    saved = json.loads(str(contents["fingerprint"]))
    written = saved.get("format")
    if written not in READABLE:
        raise CheckpointError(f"checkpoint {path}: format {written}, which this version of fsivsp does not read "
                              f"(it reads formats {READABLE[0]}–{READABLE[-1]}); run the case again without --resume")
    problems = _mismatches({**saved, "format": FORMAT}, current)
    if problems:
        raise CheckpointError(f"checkpoint {path}: does not match this run: {'; '.join(problems)}")
    present = {name: target for name, target in targets.items()
               if name in contents or added(name) <= written}
    for name, target in present.items():
        values = contents.get(name)
        if values is None or values.shape != target.shape:
            raise CheckpointError(f"checkpoint {path}: {name} has shape {None if values is None else values.shape}, "
                                  f"expected {target.shape}")
    return {name: contents[name] for name in present}


def _step(path: Path) -> int:
    digits = path.name.split(".")[0].rsplit("_", 1)[-1]
    return int(digits) if digits.isdigit() else -1


def prune_checkpoints(directory: str | Path, keep: int = 2) -> None:
    """Delete all but the ``keep`` newest checkpoints (by step) in ``directory``, each manifest before its parts,
    and the parts of older steps left without a manifest (a run stopped while writing them)."""
    directory = Path(directory)
    found = sorted(directory.glob(f"{PREFIX}_*.npz"), key=_step)
    old = found[:-keep] if keep > 0 else found
    for manifest in old:
        manifest.unlink(missing_ok=True)
    oldest = _step(found[max(len(found) - keep, 0)]) if found and keep > 0 else float("inf")
    for parts in directory.glob(f"{PREFIX}_*.parts"):
        if _step(parts) < oldest or parts.with_suffix(".npz") in old:
            shutil.rmtree(parts, ignore_errors=True)


def latest_checkpoint(directory: str | Path, report=None) -> Path | None:
    """The readable ``checkpoint*.npz`` in ``directory`` with the highest step (the newest
    file among equal steps), or None. Temporary and unreadable files are skipped, and manifests whose ranks' parts
    are missing; ``report(path, reason)`` is told of each one."""
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
                ranks = int(data["ranks"]) if "ranks" in data.files else 0
            if missing := [rank for rank in range(ranks) if not part_path(path, rank).is_file()]:
                raise CheckpointError(f"the parts of ranks {', '.join(map(str, missing))} are missing")
        except Exception as error:  # a damaged or foreign file is no candidate
            if report is not None:
                report(path, error)
            continue
        key = (step, path.stat().st_mtime_ns, path.name)
        if best_key is None or key > best_key:
            best, best_key = path, key
    return best
