"""A run's frames for the tools physicists use: extended XYZ (OVITO, ASE) and VTK polylines
(ParaView).  Positions in the run's length unit (m for a chain given in SI, else b)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .files import check_writable
from .result import Result, unit_of

FORMATS = ("xyz", "vtk")


def _landed_points(anchored: np.ndarray) -> np.ndarray:
    return anchored.astype(np.int64)


def write_xyz(result: Result, path, frames: np.ndarray, *, force: bool = False) -> Path:
    """Extended XYZ, one block per frame: the N+1 points of the chain from the top (point
    N is the pivot), species ``P``, position, and whether the floor holds the point
    (``anchored``); the comment line gives the time, its unit and the length unit.
    Returns the path."""
    p = check_writable(path, force)
    tu, lu = unit_of("frame_t", result.units), unit_of("anchor_pos", result.units)
    tmp = p.with_name(f".{p.name}.tmp")
    with open(tmp, "w") as fh:
        for i in frames:
            pts = result.points(slice(int(i), int(i) + 1))[0]
            anch = _landed_points(np.asarray(result.frame_anchored[i]))
            fh.write(f"{pts.shape[0]}\n")
            fh.write(
                f'Properties=species:S:1:pos:R:3:anchored:I:1 Time={result.frame_t[i]:.17g} time_unit="{tu}" '
                f'length_unit="{lu}" frame={int(i)} pbc="F F F"\n'
            )
            for (x, y, z), a in zip(pts, anch):
                fh.write(f"P {x:.17g} {y:.17g} {z:.17g} {a}\n")
    tmp.replace(p)
    return p


def vtk_frame_names(collection, count: int) -> list[str]:
    """The names of the ``count`` frame files ``write_vtk`` writes beside ``collection``
    (``<stem>_<k>.vtk``, k from 0)."""
    stem = Path(collection).stem
    width = max(4, len(str(count)))
    return [f"{stem}_{k:0{width}d}.vtk" for k in range(count)]


def write_vtk(result: Result, path, frames: np.ndarray, *, force: bool = False) -> Path:
    """VTK: one legacy ASCII POLYDATA file per frame (``<stem>_<k>.vtk``: the chain as one
    polyline through its N+1 points, point data ``anchored``) and a ParaView collection
    ``path`` (``.pvd``) that lists them with their times.  Returns the ``.pvd`` path."""
    p = check_writable(path, force)
    if p.suffix.lower() != ".pvd":
        raise ValueError(f"--out: the VTK collection is a .pvd file, got {str(path)!r}")
    names = vtk_frame_names(p, len(frames))
    for name in names:  # the frame files beside the collection: none replaced without force
        check_writable(p.parent / name, force)
    entries = []
    for k, i in enumerate(frames):
        pts = result.points(slice(int(i), int(i) + 1))[0]
        anch = _landed_points(np.asarray(result.frame_anchored[i]))
        name = names[k]
        n = pts.shape[0]
        lines = [
            "# vtk DataFile Version 3.0",
            f"ballchain frame {int(i)} t={result.frame_t[i]:.17g}",
            "ASCII",
            "DATASET POLYDATA",
            f"POINTS {n} double",
            *(f"{x:.17g} {y:.17g} {z:.17g}" for x, y, z in pts),
            f"LINES 1 {n + 1}",
            " ".join([str(n), *map(str, range(n))]),
            f"POINT_DATA {n}",
            "SCALARS anchored int 1",
            "LOOKUP_TABLE default",
            *map(str, anch),
        ]
        (p.parent / name).write_text("\n".join(lines) + "\n")
        entries.append(f'    <DataSet timestep="{result.frame_t[i]:.17g}" part="0" file="{name}"/>')
    p.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
        + "\n".join(entries)
        + "\n  </Collection>\n</VTKFile>\n"
    )
    return p


def export_frames(result: Result, fmt: str, path, frames: np.ndarray, *, force: bool = False) -> Path:
    """Write the frames ``frames`` (indices) of ``result`` in format ``fmt`` (``FORMATS``)."""
    if fmt == "xyz":
        return write_xyz(result, path, frames, force=force)
    if fmt == "vtk":
        return write_vtk(result, path, frames, force=force)
    raise ValueError(f"--format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
