"""Checkpoints: exact restart, refusal of foreign checkpoints, atomic writes."""
import numpy as np
import pytest

import fsivsp
from fsivsp.io import checkpoint
from fsivsp.io.checkpoint import CheckpointError, checkpoint_path, latest_checkpoint, load_checkpoint, save_checkpoint
from fsivsp.model.expressions import parse_vector


@pytest.fixture(scope="module")
def mesh():
    return fsivsp.refined(fsivsp.paper_channel(), 0)


def make_scheme(mesh, dt=1e-2, materials=None):
    spaces = fsivsp.build_spaces(mesh, "mini", dirichlet="solid_wall")
    bump = fsivsp.Field(parse_vector(["sin(pi*x/2.5)*sin(pi*y/0.41)", "0"], "velocity0", 2))
    return fsivsp.Scheme(spaces, materials or fsivsp.Materials(), fsivsp.Data(velocity0=bump, displacement0=bump),
                                dt=dt)


def vectors(scheme):
    """The state: (vⁿ, pⁿ) and the displacement uⁿ_h, which gives σⁿ_h."""
    return [scheme.state.vec.FV().NumPy().copy(), scheme.carried.vec.FV().NumPy().copy()]


def test_resume_is_bit_identical(tmp_path, mesh):
    full = make_scheme(mesh)
    for _ in range(5):
        full.step()
    path = save_checkpoint(checkpoint_path(tmp_path, full.n), full,
                           {"energies": [1.5, float("nan")], "pvd": [[0.05, "f.vtu"]]})
    assert path.name == "checkpoint_000005.npz"
    for _ in range(5):
        full.step()

    resumed = make_scheme(mesh)
    extra = load_checkpoint(latest_checkpoint(tmp_path), resumed)
    assert extra["pvd"] == [[0.05, "f.vtu"]] and np.isnan(extra["energies"][1])
    assert (resumed.n, resumed.time) == (5, 0.05)
    for _ in range(5):
        resumed.step()

    assert resumed.n == full.n == 10
    assert resumed.time == full.time
    for a, b in zip(vectors(resumed), vectors(full)):
        assert np.array_equal(a, b)
    assert resumed.energy() == full.energy()


def test_foreign_checkpoint_is_refused(tmp_path, mesh):
    source = make_scheme(mesh)
    source.step()
    path = save_checkpoint(tmp_path / "checkpoint.npz", source, {})

    other = make_scheme(mesh, dt=2e-2)
    before = vectors(other)
    with pytest.raises(CheckpointError) as info:
        load_checkpoint(path, other)
    message = str(info.value)
    assert "\n" not in message and str(path) in message
    assert "dt 0.01 (checkpoint) vs 0.02 (this run)" in message
    assert all(np.array_equal(a, b) for a, b in zip(vectors(other), before))
    assert (other.n, other.time) == (0, 0.0)

    finer = make_scheme(fsivsp.refined(mesh, 1))
    with pytest.raises(CheckpointError, match="ndof_velocity"):
        load_checkpoint(path, finer)
    stiffer = make_scheme(mesh, materials=fsivsp.Materials(mu=1.0))
    with pytest.raises(CheckpointError, match="materials.mu 0.5 .checkpoint. vs 1.0 .this run."):
        load_checkpoint(path, stiffer)
    assert issubclass(CheckpointError, ValueError)


def test_failed_save_keeps_good_checkpoint(tmp_path, mesh, monkeypatch):
    scheme = make_scheme(mesh)
    scheme.step()
    path = save_checkpoint(tmp_path / "checkpoint_000001.npz", scheme, {"a": 1})
    good = path.read_bytes()
    scheme.step()

    def crash(handle, **arrays):
        handle.write(b"PK\x03\x04 half a zip")
        raise OSError("disk full")

    monkeypatch.setattr(checkpoint.np, "savez_compressed", crash)
    with pytest.raises(OSError, match="disk full"):
        save_checkpoint(path, scheme, {"a": 2})
    monkeypatch.undo()
    with pytest.raises(TypeError):
        save_checkpoint(path, scheme, {"not json": object()})

    assert path.read_bytes() == good
    assert sorted(p.name for p in tmp_path.iterdir()) == ["checkpoint_000001.npz"]
    fresh = make_scheme(mesh)
    assert load_checkpoint(path, fresh) == {"a": 1} and fresh.n == 1


def test_latest_and_damaged_checkpoints(tmp_path, mesh):
    assert latest_checkpoint(tmp_path) is None
    assert latest_checkpoint(tmp_path / "missing") is None
    scheme = make_scheme(mesh)
    for _ in range(5):
        scheme.step()
        if scheme.n in (2, 5):
            save_checkpoint(checkpoint_path(tmp_path, scheme.n), scheme)
    (tmp_path / "checkpoint_000009.npz").write_bytes(b"garbage")
    (tmp_path / ".checkpoint_000007.npz.x.tmp").write_bytes(b"PK")
    assert latest_checkpoint(tmp_path) == tmp_path / "checkpoint_000005.npz"
    with pytest.raises(CheckpointError, match="checkpoint_000009.npz: not a readable checkpoint"):
        load_checkpoint(tmp_path / "checkpoint_000009.npz", scheme)


def older_format(path, written: int, tmp_path):
    """The checkpoint ``path`` as a version of format ``written`` wrote it: without the vectors added since."""
    import json
    with np.load(path) as data:
        arrays = {name: data[name] for name in data.files if checkpoint.added(name) <= written}
    saved = json.loads(str(arrays["fingerprint"]))
    arrays["fingerprint"] = np.array(json.dumps({**saved, "format": written}, sort_keys=True))
    arrays["format"] = np.array(written, dtype=np.int64)
    old = tmp_path / f"format{written}" / path.name
    old.parent.mkdir()
    np.savez_compressed(old, **arrays)
    return old


def test_formats_3_and_4_are_read_and_older_ones_refused(tmp_path, mesh):
    """A checkpoint of format 3 (before the warm start kept xⁿ⁻¹) resumes: the next step starts from xⁿ, as format 3's
    runs did, and the state is the one saved; one of format 4 brings its xⁿ⁻¹ to the start; format 2 is refused in
    one line."""
    scheme = make_scheme(mesh)
    for _ in range(3):
        scheme.step()
    path = save_checkpoint(checkpoint_path(tmp_path, scheme.n), scheme, {"a": 1})
    assert "previous_solution" in np.load(path).files

    resumed = make_scheme(mesh)
    assert load_checkpoint(older_format(path, 3, tmp_path), resumed) == {"a": 1}
    assert resumed.n == 3
    for a, b in zip(vectors(resumed), vectors(scheme)):
        assert np.array_equal(a, b)
    assert resumed.warm.count[0] == 1 < scheme.warm.count[0]   # xⁿ alone: the next step starts from xⁿ
    fourth = make_scheme(mesh)   # format 4 held xⁿ⁻¹
    load_checkpoint(older_format(path, 4, tmp_path), fourth)
    assert fourth.warm.count[0] == 2
    assert np.array_equal(fourth.warm.solutions[1].FV().NumPy(), scheme.warm.solutions[1].FV().NumPy())

    with pytest.raises(CheckpointError) as info:
        load_checkpoint(older_format(path, 2, tmp_path), make_scheme(mesh))
    assert "\n" not in str(info.value) and "format 2, which this version of fsivsp does not read" in str(info.value)
