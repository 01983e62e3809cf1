"""Result files: one self-describing HDF5 file per run.

Layout (format ``ballchain-result``, version 6)::

    /                 attrs (ROOT_ATTRS): format, format_version, package_version (the
                      ballchain version that wrote the file), version (that ran it),
                      engine (the fingerprint of the engine's sources that ran it),
                      units, created (UTC, ISO 8601), status, message, seed,
                      params_json, ic_json, options_json, energy_json, extra_json
    /params           attrs: one per ChainParams field (for h5dump readers)
    /ic               attrs: one per InitialCondition field (absent if ic is None)
    /options          attrs: one per SolverOptions field (None is written as "none")
    /summary          0-d datasets z0, t_ff, t_fall, t_landed, max_depth, wall_seconds,
                      n_steps, n_evals, n_instants; floor_impulse (3,), floor_impulse_total (3,)
    /trace            t, z_top
    /frames           frame_t, frame_e, frame_omega, frame_anchored, frame_locked,
                      frame_floor_force, frame_pile_pull, frame_scale_force,
                      frame_floor_impulse, frame_kinetic, frame_potential,
                      frame_lost_locking, frame_lost_landing, frame_lost_damping,
                      frame_base, frame_base_velocity, frame_lost_sliding, frame_tension
                      attrs: conventions (numbering, directions, positions, axes)
    /events           event_t, event_kind, event_index, event_impulse, event_energy,
                      event_pos; attrs: kinds (JSON code -> name), kind_meanings
    /anchors          anchor_t, anchor_pos
    /energy           attrs: the final energy budget (and ``units``)

Every dataset carries a ``units`` and a ``description`` attribute.  Arrays are chunked
along their first axis with a Fletcher-32 checksum (damaged data is detected on
reading); large ones are compressed (shuffle + gzip, lossless).  The JSON
attributes are what ``load_result`` reads back, so that parameters round-trip exactly;
the per-field attributes are for humans.

Writing is atomic: the file is written under a temporary name in the target
directory and moved into place only when complete; on any failure (including
KeyboardInterrupt) the temporary file is removed.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import json
import os
import secrets
import stat
from pathlib import Path

import numpy as np

from .. import __version__
from ..model import ChainParams, InitialCondition, ParameterError, SolverOptions
from .result import EVENT_KINDS, EVENT_MEANINGS, Result, unit_of

FORMAT_NAME = "ballchain-result"
FORMAT_VERSION = 6  # 6: the tension at every point per frame; 5: friction's work on sliding points per frame; 4: the smooth laws' loss per frame; 3: the sliding bottom end; 2: floor momentum record, event positions, kind 8; version 1 files load (NaN)
# 3: the bottom end's position and velocity (a frictionless floor); version 1 and 2 files load (zeros)

# the root attributes, each with what it holds (the site's page of the layout lists them from here)
ROOT_ATTRS = {
    "format": f"the format's name, {FORMAT_NAME}",
    "format_version": "the layout's version (a newer one than the reader knows is refused)",
    "package_version": "the ballchain version that wrote the file (what ballchain --version printed)",
    "version": "the ballchain version that ran the fall (Result.version)",
    "engine": "the fingerprint of the engine's sources that ran the fall (Result.engine; runs of one engine rerun exactly)",
    "units": "the units of every dataset: nondimensional or SI",
    "created": "when the file was written (UTC, ISO 8601)",
    "status": "how the run ended: landed, until, max_time, error or interrupted",
    "message": "why the run stopped early ('' if it did not)",
    "seed": "the start's SeedSequence entropy (absent for an explicit state)",
    "params_json": "ChainParams as JSON (what load_result reads back, exactly)",
    "ic_json": "InitialCondition as JSON (null for an explicit state)",
    "options_json": "SolverOptions as JSON",
    "energy_json": "the final energy budget as JSON",
    "extra_json": "what else the run recorded, as JSON (a dataset of that name when it exceeds 32 KiB)",
}

CONVENTIONS = (
    "Segments i = 0..N-1 are numbered from the top end of the chain, points j = 0..N "
    "from the top too: segment i joins point i (its upper end) and point i+1 (its lower "
    "end); hinge k (0..N-2) is point k+1. frame_e[:, i] is the unit axis e_i of segment i, "
    "pointing up the chain (from point i+1 to point i). Point N, the original pivot, is at "
    "the origin and is anchored from t = 0 (on a frictionless floor, params friction 0, it "
    "slides: it is at frame_base); point j is at r_j = r_N + 2 b sum_{i>=j} e_i "
    "(Result.points()). z points up, the floor is z = 0, gravity is -g e_z. b is the "
    "half-length of a segment (params.half_length; 1 in nondimensional units), m its mass."
)

# big datasets (bytes) are chunked + compressed
_COMPRESS_MIN_BYTES = 16 * 1024
_CHUNK_BYTES = 1 << 20

GROUPS = {
    "summary": (
        "z0",
        "t_ff",
        "t_fall",
        "t_landed",
        "max_depth",
        "floor_impulse",
        "floor_impulse_total",
        "wall_seconds",
        "n_steps",
        "n_evals",
        "n_instants",
    ),
    "trace": ("t", "z_top"),
    "frames": (
        "frame_t",
        "frame_e",
        "frame_omega",
        "frame_anchored",
        "frame_locked",
        "frame_floor_force",
        "frame_pile_pull",
        "frame_scale_force",
        "frame_floor_impulse",
        "frame_kinetic",
        "frame_potential",
        "frame_lost_locking",
        "frame_lost_landing",
        "frame_lost_damping",
        "frame_base",
        "frame_base_velocity",
        "frame_lost_sliding",
        "frame_tension",
    ),
    "events": ("event_t", "event_kind", "event_index", "event_impulse", "event_energy", "event_pos"),
    "anchors": ("anchor_t", "anchor_pos"),
}
# datasets that version 1 files lack (read back as NaN), by their shape
_NEW_IN_V2 = {
    "floor_impulse_total": lambda nf, ne: (3,),
    "frame_pile_pull": lambda nf, ne: (nf, 3),
    "frame_scale_force": lambda nf, ne: (nf,),
    "frame_floor_impulse": lambda nf, ne: (nf, 3),
    "event_pos": lambda nf, ne: (ne, 3),
}
# datasets that version 1 and 2 files lack (read back as zeros: the bottom end then never left the origin)
_NEW_IN_V3 = {
    "frame_base": lambda nf, ne: (nf, 3),
    "frame_base_velocity": lambda nf, ne: (nf, 3),
}
# datasets that files before version 4 lack (read back as zeros: no smooth law acted before it)
_NEW_IN_V4 = {
    "frame_lost_damping": lambda nf, ne: (nf,),
}
# datasets that files before version 5 lack (read back as zeros: their lost_landing held the friction's work)
_NEW_IN_V5 = {
    "frame_lost_sliding": lambda nf, ne: (nf,),
}
# datasets that files before version 6 lack (read back as NaN: not computed)
_NEW_IN_V6 = {"frame_tension"}
_FLOAT_SCALARS = ("z0", "t_ff", "t_fall", "t_landed", "max_depth", "wall_seconds")
_INT_SCALARS = ("n_steps", "n_evals", "n_instants")

DESCRIPTIONS = {
    "z0": "height of the top end at t = 0",
    "t_ff": "free-fall time sqrt(2 z0 / g)",
    "t_fall": "first time the top end reaches the floor (NaN: not reached)",
    "t_landed": "time the last segment landed (NaN: not reached)",
    "max_depth": "deepest airborne point below the floor (floor = pivot; 0 if none)",
    "floor_impulse": "sum of the floor's impulses on the chain at every impact (x, y, z), landings and anchored points",
    "floor_impulse_total": "the floor's whole impulse on the chain from t = 0 to the end (x, y, z): impacts, "
    "continuous force (integrated by the integrator's quadrature) and the support of landed "
    "segments; = M (v_cm(end) - v_cm(0)) + M g t_end e_z",
    "wall_seconds": "wall-clock duration of the run",
    "n_steps": "accepted integrator steps",
    "n_evals": "evaluations of the equations of motion",
    "n_instants": "event instants handled (one instant can log many rows)",
    "t": "trace times (every accepted step and event)",
    "z_top": "height of the top end of the chain at the trace times",
    "frame_t": "output frame times",
    "frame_e": "unit axis e_n of each segment (F, N, 3), segments numbered from the top",
    "frame_omega": "angular velocity of each segment (F, N, 3)",
    "frame_anchored": "point j anchored to the floor (F, N+1), points counted from the top",
    "frame_locked": "hinge k between segments k and k+1 locked (F, N-1)",
    "frame_floor_force": "continuous force of all anchors on the airborne chain (F, 3)",
    "frame_pile_pull": "force of the pile on the hanging chain through the first anchored point from the top "
    "(F, 3; z < 0: a pull down; 0 when the top end is anchored)",
    "frame_scale_force": "vertical force a scale under the floor reads: the anchors' z force plus the weight "
    "of the landed segments (impulses excluded)",
    "frame_floor_impulse": "the floor's cumulative impulse on the chain from t = 0 (F, 3), impacts included",
    "frame_base": "the position of point N, the bottom end (F, 3): zero unless it slides (a frictionless floor)",
    "frame_base_velocity": "the velocity of point N, the bottom end (F, 3): zero unless it slides",
    "frame_kinetic": "kinetic energy",
    "frame_potential": "potential energy",
    "frame_lost_locking": "cumulative kinetic energy lost in hinge locking",
    "frame_lost_landing": "cumulative kinetic energy lost in landings",
    "frame_lost_damping": "cumulative energy removed by the hinges' viscous damping (its power integrated)",
    "frame_lost_sliding": "cumulative energy removed by Coulomb's friction force from sliding points (its work)",
    "frame_tension": "tension at every point (F, N+1), pulling positive: the force on the segment above point j "
    "along its axis, -F_j . e_(j-1) (a held point: the support's pull; 0 at a free end and between landed "
    "segments); the time-steppers': the mean over the step before the frame",
    "event_t": "event times, one row per constraint that acted",
    "event_kind": ", ".join(f"{c} {name}" for c, name in EVENT_KINDS.items()) + " (docs/measures.md, 'The event log')",
    "event_index": "hinge k (0..N-2) or point j (0..N, from the top) of the event",
    "event_impulse": "lock, impulse, hold: (Lambda, 0, 0); landing, anchor: impulse of the floor on the chain",
    "event_pos": "position of the hinge (point k+1) or point j of the row at the event (E, 3)",
    "event_energy": "kinetic energy dissipated by that constraint",
    "anchor_t": "time each point was anchored (NaN: never; 0: the pivot)",
    "anchor_pos": "position where each point was anchored (N+1, 3)",
}


class ResultFileError(ValueError):
    """A result file that cannot be read or written; the message is one line."""


# --------------------------------------------------------------------------- helpers
def _one_line(exc: BaseException) -> str:
    text = str(exc).strip() or type(exc).__name__
    return text.splitlines()[0].strip()


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot store a {type(obj).__name__} in a result file (not JSON serialisable)")


def _dumps(obj) -> str:
    # allow_nan: Python's json writes/reads NaN and Infinity exactly
    return json.dumps(obj, default=_json_default, allow_nan=True)


def _attr_value(v):
    """A value for an HDF5 attribute (h5dump-friendly)."""
    if v is None:
        return "none"
    if isinstance(v, (bool, np.bool_)):
        return np.bool_(v)
    if isinstance(v, (int, float, str, np.generic)):
        return v
    return _dumps(v)


def _writable_dir(directory: Path) -> str | None:
    """None if files can be created in ``directory``, else the reason."""
    if not directory.exists():
        return f"directory {str(directory)!r} does not exist"
    if not directory.is_dir():
        return f"{str(directory)!r} is not a directory"
    probe = directory / f".ballchain-probe-{os.getpid()}-{secrets.token_hex(4)}.tmp"
    try:
        fd = os.open(probe, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
    except OSError as e:
        return f"cannot create files in {str(directory)!r} ({e.strerror or _one_line(e)})"
    os.close(fd)
    try:
        os.unlink(probe)
    except OSError:
        pass
    return None


def _exists_message(p: Path, what: str) -> str:
    """A file is in the way: how to replace it, in the caller's terms (an option of the
    command line, ``--output``, or a keyword of Python, ``path``)."""
    how = "use --force to overwrite" if what.startswith("--") else "pass force=True to overwrite"
    return f"{what}: file {str(p)!r} exists ({how})"


def check_writable(path, force: bool = False, what: str = "path") -> Path:
    """Fail early (before any simulation work) if ``path`` cannot be written.

    Raises FileExistsError if the file exists and ``force`` is false, ResultFileError
    if the path is a directory, a symbolic link (refused: name the file it points to), a
    device, FIFO or socket (``force`` replaces only a regular file), or its directory is
    missing or not writable.  Returns the path as a ``Path``.  ``what`` names the path
    in the messages: the command-line option (``--output``) or the Python argument.
    """
    p = Path(path)
    if str(path) == "" or p.name == "":
        raise ResultFileError(f"{what}: {str(path)!r} is not a file name")
    if p.is_symlink():
        raise ResultFileError(f"{what}: {str(p)!r} is a symbolic link (refused: give the file it points to)")
    if p.is_dir():
        raise ResultFileError(f"{what}: {str(p)!r} is a directory")
    if p.exists():
        if not stat.S_ISREG(p.stat().st_mode):
            raise ResultFileError(f"{what}: {str(p)!r} is not a regular file (a device, FIFO or socket): refused")
        if not force:
            raise FileExistsError(_exists_message(p, what))
    reason = _writable_dir(p.parent if str(p.parent) else Path("."))
    if reason is not None:
        raise ResultFileError(f"{what}: cannot write {str(p)!r}: {reason}")
    return p


def check_output_dir(path, what: str = "--out") -> Path:
    """Fail early if ``path`` cannot be (or become) a directory to write files into: an
    existing path must be a writable directory; a new one needs a writable parent
    (it is created when the work starts).  Raises ResultFileError naming ``what``."""
    p = Path(path)
    if str(path) == "":
        raise ResultFileError(f"{what}: empty directory name")
    if p.exists() or p.is_symlink():
        if not p.is_dir():
            raise ResultFileError(f"{what}: {str(p)!r} exists and is not a directory")
        reason = _writable_dir(p)
    else:
        reason = _writable_dir(p.parent if str(p.parent) else Path("."))
    if reason is not None:
        raise ResultFileError(f"{what}: cannot write into {str(p)!r}: {reason}")
    return p


# --------------------------------------------------------------------------- writing
def _create(group, name: str, data, units: str) -> None:
    arr = np.asarray(data)
    kw = {}
    if arr.ndim >= 1 and arr.size > 0:
        # chunked (along the first axis) so that every array carries a checksum;
        # big ones are also compressed (lossless)
        row_bytes = max(1, arr.nbytes // arr.shape[0])
        rows = int(max(1, min(arr.shape[0], _CHUNK_BYTES // row_bytes)))
        kw = dict(chunks=(rows,) + arr.shape[1:], fletcher32=True)
        if arr.nbytes >= _COMPRESS_MIN_BYTES:
            kw.update(compression="gzip", compression_opts=4, shuffle=True)
    ds = group.create_dataset(name, data=arr, **kw)
    ds.attrs["units"] = unit_of(name, units)
    ds.attrs["description"] = DESCRIPTIONS.get(name, name)


def _write(f, result: Result) -> None:
    units = str(result.units)
    f.attrs["format"] = FORMAT_NAME
    f.attrs["format_version"] = np.int64(FORMAT_VERSION)
    f.attrs["package_version"] = __version__
    f.attrs["version"] = str(result.version)
    f.attrs["engine"] = str(result.engine)
    f.attrs["units"] = units
    f.attrs["created"] = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
    f.attrs["status"] = str(result.status)
    f.attrs["message"] = str(result.message)
    if result.ic is not None:
        f.attrs["seed"] = np.int64(result.ic.seed)
    f.attrs["params_json"] = _dumps(result.params.to_dict())
    f.attrs["ic_json"] = _dumps(None if result.ic is None else result.ic.to_dict())
    f.attrs["options_json"] = _dumps(result.options.to_dict())
    f.attrs["energy_json"] = _dumps(dict(result.energy))
    extra = _dumps(dict(result.extra))
    if len(extra.encode()) < 32 * 1024:
        f.attrs["extra_json"] = extra
    else:  # attributes are limited to 64 KiB: keep big blobs in a dataset
        f.create_dataset("extra_json", data=extra)

    for gname, obj in (("params", result.params), ("ic", result.ic), ("options", result.options)):
        if obj is None:
            continue
        g = f.create_group(gname)
        for k, v in obj.to_dict().items():
            g.attrs[k] = _attr_value(v)

    for gname, names in GROUPS.items():
        g = f.create_group(gname)
        for name in names:
            _create(g, name, getattr(result, name), units)
        if gname == "frames":
            g.attrs["conventions"] = CONVENTIONS
        if gname == "events":
            g.attrs["kinds"] = _dumps({str(c): name for c, name in EVENT_KINDS.items()})
            g.attrs["kind_meanings"] = _dumps({name: EVENT_MEANINGS[name] for name in EVENT_KINDS.values()})

    g = f.create_group("energy")
    g.attrs["units"] = unit_of("frame_kinetic", units)
    g.attrs["description"] = "energy budget at the end of the run"
    for k, v in result.energy.items():
        g.attrs[str(k)] = _attr_value(v)


def save_result(result: Result, path, *, force: bool = False, what: str = "path") -> Path:
    """Write ``result`` to the HDF5 file ``path`` atomically; return the path.

    An existing file is replaced only with ``force=True`` (else FileExistsError).
    ``what`` names the path in the messages (``--output`` from the command line).
    """
    import h5py

    p = Path(path)
    check_writable(p, force, what)
    tmp = p.parent / f".{p.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
    try:
        try:
            f = h5py.File(tmp, "w-")
        except OSError as e:
            raise ResultFileError(f"{what}: cannot write {str(p)!r} ({_one_line(e)})") from None
        with f:
            _write(f, result)
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        if force:
            os.replace(tmp, p)
        else:
            try:  # atomic no-clobber: link fails if the target appeared meanwhile
                os.link(tmp, p)
            except FileExistsError:
                raise FileExistsError(_exists_message(p, what)) from None
            except OSError:  # file system without hard links
                if p.exists():
                    raise FileExistsError(_exists_message(p, what)) from None
                os.replace(tmp, p)
    finally:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
    return p


# --------------------------------------------------------------------------- reading
def _known(cls, d: dict) -> dict:
    names = {f.name for f in dataclasses.fields(cls)}
    return {k: v for k, v in d.items() if k in names}


def _str_attr(attrs, name, default=None):
    if name not in attrs:
        return default
    v = attrs[name]
    if isinstance(v, bytes):
        v = v.decode("utf-8")
    if isinstance(v, np.ndarray) and v.shape == ():
        v = v[()]
        if isinstance(v, bytes):
            v = v.decode("utf-8")
    return v


def _read(f, where: str) -> Result:
    def need_attr(name):
        if name not in f.attrs:
            raise ResultFileError(f"{where}: damaged result file (missing attribute {name!r})")
        return _str_attr(f.attrs, name)

    def need(group, name):
        key = f"{group}/{name}"
        if key not in f:
            raise ResultFileError(f"{where}: damaged result file (missing dataset /{key})")
        return f[key][()]

    params = ChainParams(**_known(ChainParams, json.loads(need_attr("params_json"))))
    ic_d = json.loads(need_attr("ic_json"))
    ic = None if ic_d is None else InitialCondition(**_known(InitialCondition, ic_d))
    options = SolverOptions(**_known(SolverOptions, json.loads(need_attr("options_json"))))
    energy = json.loads(need_attr("energy_json"))
    if "extra_json" in f.attrs:
        extra = json.loads(_str_attr(f.attrs, "extra_json"))
    elif "extra_json" in f:
        raw = f["extra_json"][()]
        extra = json.loads(raw.decode("utf-8") if isinstance(raw, bytes) else raw)
    else:
        extra = {}

    kw = {}
    for gname, names in GROUPS.items():
        for name in names:
            if name in {*_NEW_IN_V2, *_NEW_IN_V3, *_NEW_IN_V4, *_NEW_IN_V5, *_NEW_IN_V6} and f"{gname}/{name}" not in f:
                continue  # a file of an earlier version: filled in below
            kw[name] = need(gname, name)
    nf, ne = kw["frame_t"].shape[0], kw["event_t"].shape[0]
    for name, shape in _NEW_IN_V2.items():
        kw.setdefault(name, np.full(shape(nf, ne), np.nan))
    for name, shape in (_NEW_IN_V3 | _NEW_IN_V4 | _NEW_IN_V5).items():
        kw.setdefault(name, np.zeros(shape(nf, ne)))
    kw.setdefault("frame_tension", np.full((nf, params.segments + 1), np.nan))
    for name in _FLOAT_SCALARS:
        kw[name] = float(kw[name])
    for name in _INT_SCALARS:
        kw[name] = int(kw[name])
    return Result(
        params=params,
        ic=ic,
        options=options,
        version=str(need_attr("version")),
        status=str(need_attr("status")),
        message=str(need_attr("message")),
        energy=energy,
        units=str(need_attr("units")),
        extra=extra,
        engine=_str_attr(f.attrs, "engine", "unknown"),
        **kw,
    )


def _open(path):
    import h5py

    p = Path(path)
    where = str(p)
    if not p.exists():
        raise ResultFileError(f"{where}: no such file")
    if p.is_dir():
        raise ResultFileError(f"{where}: is a directory, not a result file")
    try:
        size = p.stat().st_size
        ok = h5py.is_hdf5(p)
    except OSError as e:
        raise ResultFileError(f"{where}: cannot read ({e.strerror or _one_line(e)})") from None
    if size == 0:
        raise ResultFileError(f"{where}: empty file, not a ballchain result file")
    if not ok:
        raise ResultFileError(f"{where}: not an HDF5 file (not a ballchain result file)")
    try:
        f = h5py.File(p, "r")
    except OSError as e:
        raise ResultFileError(f"{where}: damaged or truncated HDF5 file ({_one_line(e)})") from None
    try:
        fmt = _str_attr(f.attrs, "format")
        if fmt != FORMAT_NAME:
            raise ResultFileError(
                f"{where}: not a ballchain result file (HDF5 file without format attribute {FORMAT_NAME!r})"
            )
        ver = f.attrs.get("format_version")
        try:
            ver_i = int(ver)
            if ver_i != ver:
                raise ValueError
        except (TypeError, ValueError):
            raise ResultFileError(f"{where}: damaged result file (bad format_version {ver!r})") from None
        if ver_i > FORMAT_VERSION:
            pv = _str_attr(f.attrs, "package_version", "?")
            raise ResultFileError(
                f"{where}: written by a newer ballchain ({pv}, format version "
                f"{ver_i} > {FORMAT_VERSION}); upgrade ballchain to read it"
            )
        if ver_i < 1:
            raise ResultFileError(f"{where}: damaged result file (bad format_version {ver_i})")
    except ResultFileError:
        f.close()
        raise
    except Exception as e:  # damaged metadata
        f.close()
        raise ResultFileError(f"{where}: damaged result file ({type(e).__name__}: {_one_line(e)})") from None
    except BaseException:
        f.close()
        raise
    return f, where


def load_result(path) -> Result:
    """Read a file written by ``save_result``; raises ResultFileError (one line) for a
    missing, non-HDF5, truncated/damaged, foreign or newer-format file."""
    f, where = _open(path)
    with f:
        try:
            return _read(f, where)
        except ResultFileError:
            raise
        except (ParameterError, json.JSONDecodeError) as e:
            raise ResultFileError(f"{where}: damaged result file (bad parameters: {_one_line(e)})") from None
        except Exception as e:  # h5py raises OSError/KeyError/ValueError on damaged data
            raise ResultFileError(f"{where}: damaged result file ({type(e).__name__}: {_one_line(e)})") from None


def file_info(path) -> dict:
    """Root metadata of a result file (format, versions, units, creation time)."""
    f, _ = _open(path)
    with f:
        info = {
            k: _str_attr(f.attrs, k)
            for k in ("format", "package_version", "version", "units", "created", "status")
            if k in f.attrs
        }
        info["format_version"] = int(f.attrs["format_version"])
        return info
