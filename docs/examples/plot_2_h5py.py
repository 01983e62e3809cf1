"""
Reading a result file with h5py
===============================

A result file is plain HDF5: every dataset carries its unit and a description
(the layout page lists them all). Here with h5py alone, no ballchain needed to read it.
"""

import tempfile
from pathlib import Path

import h5py
import matplotlib.pyplot as plt
import numpy as np

import ballchain as bc

path = Path(tempfile.mkdtemp()) / "run.h5"
bc.save(bc.simulate(segments=12, alpha="pi/3", until=0.9), path)

with h5py.File(path) as f:
    print("status:", f.attrs["status"], "| engine:", f.attrs["engine"], "| units:", f.attrs["units"])
    print("groups:", list(f))
    t, z = f["trace/t"][:], f["trace/z_top"][:]
    e = f["frames/frame_e"][:]  # (frames, N, 3) segment axes, from the top
    ft = f["frames/frame_t"][:]
    print("frames/frame_e:", e.shape, "-", f["frames/frame_e"].attrs["description"])
    t_ff = f["summary/t_ff"][()]

# the points' heights from the axes: point j is 2 b sum_{i >= j} e_i,z above the pivot
heights = 2.0 * np.cumsum(e[:, ::-1, 2], axis=1)[:, ::-1]
fig, ax = plt.subplots(figsize=(6, 3.5))
ax.plot(t / t_ff, z, label="z_top (trace)")
ax.plot(ft / t_ff, heights[:, 0], "o", ms=3, label="z_top from the frames")
ax.set_xlabel("t / t_ff")
ax.set_ylabel("height / b")
ax.legend()
